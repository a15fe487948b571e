// Connected regions of valid pixels split at depth jumps: what a speckle filter counts.
#pragma once

#include <cstdint>
#include <vector>

#include "../views.hpp"

namespace rangemesh {

// Label the valid pixels' regions: 8-neighbours a, b (both valid) are joined when
// |za - zb| <= share * min(|za|, |zb|) * L, L = 1 along a row or column and sqrt(2) across a
// diagonal (the walls' rule of refine/walls.py per pixel of length). `labels` gets each valid
// pixel's region id (0, 1, ... in row-major order of their first pixel) and -1 elsewhere;
// returns each region's pixel count.
std::vector<std::int64_t> label_regions(Grid<const double> depth, Grid<const bool> valid, double share,
                                        Grid<std::int32_t> labels);

}  // namespace rangemesh
