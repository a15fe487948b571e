// Four lanes of AVX where the compiler can target it in one function and the processor has it
// (asked at run time). The kernels that use it (the insertion's scans, the flip tests' long rows,
// the fit's pass and error sample on faces of long rows, the error bound's render and sum) keep
// their scalar loop beside it and do each lane's IEEE operations as that loop
// does, so a result never depends on whether AVX ran.
#pragma once

#include <cstdint>
#include <cstdlib>

// GCC and clang on x86; not clang-cl, whose __builtin_cpu_supports needs libgcc's __cpu_model
#if (defined(__GNUC__) || defined(__clang__)) && (defined(__x86_64__) || defined(__i386__)) && !defined(_MSC_VER)
#include <immintrin.h>
#define RANGEMESH_AVX 1
#else
#define RANGEMESH_AVX 0
#endif

namespace rangemesh {

#if RANGEMESH_AVX
// Whether the processor (and its system) runs AVX, asked once. RANGEMESH_NO_AVX set (and not
// "0") says no: the tests run the scalar loops so on a machine that has AVX.
inline bool has_avx() {
    static const bool avx = [] {
        const char* off = std::getenv("RANGEMESH_NO_AVX");
        if (off != nullptr && off[0] != '\0' && !(off[0] == '0' && off[1] == '\0')) return false;
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx") != 0;
    }();
    return avx;
}

// Four lanes' masks: lane k all ones where bit k of the index is set.
alignas(32) inline constexpr std::uint64_t LANE_MASKS[16][4] = {
    {0, 0, 0, 0},         {~0ull, 0, 0, 0},         {0, ~0ull, 0, 0},         {~0ull, ~0ull, 0, 0},
    {0, 0, ~0ull, 0},     {~0ull, 0, ~0ull, 0},     {0, ~0ull, ~0ull, 0},     {~0ull, ~0ull, ~0ull, 0},
    {0, 0, 0, ~0ull},     {~0ull, 0, 0, ~0ull},     {0, ~0ull, 0, ~0ull},     {~0ull, ~0ull, 0, ~0ull},
    {0, 0, ~0ull, ~0ull}, {~0ull, 0, ~0ull, ~0ull}, {0, ~0ull, ~0ull, ~0ull}, {~0ull, ~0ull, ~0ull, ~0ull}};
#endif

}  // namespace rangemesh
