#pragma once

// What the float32 kernel's instruction-set variants (gemm_f32_kernel.inc, compiled with their own flags) share with
// the rest of the layer: declarations only, so that no code of a header is compiled for an instruction set the CPU
// running it may lack (autograd/gemm_f32.h picks the variant).

#include <cstdint>

namespace maps::ag::detail {

// A float32 matrix read through strides: element (i, j) at data[i * row_stride + j * col_stride].
struct StridedF32 {
  const float* data;
  std::int64_t row_stride, col_stride;
};

// The variants; each exists only in a build whose compiler took its flags (gemm_f32.cpp knows which).
void gemm_f32_avx512(StridedF32 a, StridedF32 b, float* c, std::int64_t ldc, std::int64_t m, std::int64_t n,
                     std::int64_t k, bool accumulate);
void gemm_f32_avx2(StridedF32 a, StridedF32 b, float* c, std::int64_t ldc, std::int64_t m, std::int64_t n,
                   std::int64_t k, bool accumulate);
// A variant's scratch could not be allocated: throws std::bad_alloc (from gemm_f32.cpp, compiled for any CPU).
[[noreturn]] void f32_scratch_exhausted(std::int64_t floats);

}  // namespace maps::ag::detail
