// Python bindings of the regions kernel (speckle removal, rangemesh.regions).
#include <cmath>
#include <cstdint>

#include "../geometry/regions.hpp"
#include "bindings.hpp"
#include "numpy.hpp"
#include "release.hpp"

namespace rangemesh::bind {

void bind_regions(nb::module_& m) {
    m.def(
        "label_regions",
        [](In2<double> depth, In2<bool> valid, double share, Out2<std::int32_t> labels) {
            check_input(same_shape(depth, valid) && same_shape(depth, labels),
                        "label_regions: depth, valid and labels must have one shape");
            check_input(std::isfinite(share) && share >= 0.0, "label_regions: share must be finite and >= 0");
            std::vector<std::int64_t> sizes =
                run_released([&] { return label_regions(grid(depth), grid(valid), share, grid(labels)); }, work(depth));
            return to_numpy(std::move(sizes));
        },
        nb::arg("depth"), nb::arg("valid"), nb::arg("share"), nb::arg("labels").noconvert(),
        "Write each valid pixel's region id into `labels` (int32, -1 elsewhere) and return the regions' "
        "pixel counts (int64): 8-neighbours are joined unless their depths differ by more than `share` "
        "of the smaller per pixel of length (sqrt(2) across a diagonal).");
}

}  // namespace rangemesh::bind
