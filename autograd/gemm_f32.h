#pragma once

// The float32 matrix product's own kernel (AVX-512, or AVX2 + FMA), under gemm_serial. Internal to the autograd
// layer.
//
// Eigen 3.4's AVX-512 GEMM packs both operands and runs a 48x4 register tile; on this machine's cores (Zen 5) it
// reaches about 150-160 GFLOP/s on the training step's products ([320, 128] x [128, 128] and the like) and the
// packing of the cold operand costs a further 15% of a step. This kernel keeps an 8 x 32 tile of C in 16 registers
// (on AVX2: 6 x 16 in 12), broadcasts op(A)'s elements straight from memory (no packing of A, any strides) and
// reads op(B) in place or packs it into panels of the tile's width; it runs the same products at 200-230 GFLOP/s
// (AVX2: 108-114, Eigen's 98-108). Measured by `maps_bench --benchmark_filter=Gemm`
// (experiments/bench/micro/gemm_bench.cpp); docs/performance.md.
//
// Each element of C is summed in the same order (inner blocks in order, k ascending within a block) wherever its
// tile falls, so a product's result does not depend on how gemm_parallel splits it across threads.

#include <cstdint>

namespace maps::ag::detail {

// AVX-512 (8 x 32 tile) or, on CPUs without it (most laptops' Intel cores), AVX2 with FMA (6 x 16 tile, 12 of the
// 16 registers); else none and float32 runs Eigen's GEMM.
#if defined(__AVX512F__) || (defined(__AVX2__) && defined(__FMA__))
#define MAPS_F32_KERNEL 1
#else
#define MAPS_F32_KERNEL 0
#endif
inline constexpr bool kHaveF32Kernel = MAPS_F32_KERNEL;
#if defined(__AVX512F__)
inline constexpr const char* kF32KernelName = "maps AVX-512";
#elif MAPS_F32_KERNEL
inline constexpr const char* kF32KernelName = "maps AVX2";
#else
inline constexpr const char* kF32KernelName = "Eigen";
#endif

// A float32 matrix read through strides: element (i, j) at data[i * row_stride + j * col_stride].
struct StridedF32 {
  const float* data;
  std::int64_t row_stride, col_stride;
};

// C [m, n] (row-major, `ldc` between rows) = A [m, k] B [k, n], or += when `accumulate`. Only when
// kHaveF32Kernel (else it throws std::logic_error).
void gemm_f32(StridedF32 a, StridedF32 b, float* c, std::int64_t ldc, std::int64_t m, std::int64_t n, std::int64_t k,
              bool accumulate);

}  // namespace maps::ag::detail
