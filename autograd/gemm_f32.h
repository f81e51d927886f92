#pragma once

// The float32 matrix product's own kernel (AVX-512), under gemm_serial. Internal to the autograd layer.
//
// Eigen 3.4's AVX-512 GEMM packs both operands and runs a 48x4 register tile; on this machine's cores (Zen 5) it
// reaches about 150-160 GFLOP/s on the training step's products ([320, 128] x [128, 128] and the like) and the
// packing of the cold operand costs a further 15% of a step. This kernel keeps an 8 x 32 tile of C in 16 registers,
// broadcasts op(A)'s elements straight from memory (no packing of A, any strides) and packs only op(B) into
// 32-column panels; it runs the same products at 210-230 GFLOP/s. Measured by `maps_bench
// --benchmark_filter=Gemm` (experiments/benchmarks/gemm_bench.cpp); docs/performance.md.
//
// Each element of C is summed in the same order (inner blocks in order, k ascending within a block) wherever its
// tile falls, so a product's result does not depend on how gemm_parallel splits it across threads.

#include <cstdint>

namespace maps::ag::detail {

#if defined(__AVX512F__)
inline constexpr bool kHaveF32Kernel = true;
#else
inline constexpr bool kHaveF32Kernel = false;
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
