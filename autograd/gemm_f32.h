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
// The instruction set is chosen at run time (issue 44): the build compiles the kernel once for AVX-512 and once for
// AVX2 + FMA (gemm_f32_avx512.cpp, gemm_f32_avx2.cpp, each with its own flags, on x86-64 compilers that take them),
// and the first product picks the widest the CPU runs, so one portable binary runs AVX-512 on a Zen 5 or a Xeon and
// AVX2 on a Zen 3 or a laptop; elsewhere float32 runs Eigen's GEMM. MAPS_F32_KERNEL=avx512|avx2|eigen in the
// environment picks one instead (a CPU without it is refused by name). Both instruction sets sum each element of C
// in the same order (inner blocks in order, k ascending within a block, one fused multiply-add at a time), wherever
// its tile falls: a product's result depends neither on gemm_parallel's split nor on the kernel chosen.

#include <cstdint>
#include <string>
#include <vector>

#include "autograd/gemm_f32_variant.h"

namespace maps::ag::detail {

enum class F32Kernel { eigen, avx2, avx512 };

// "maps AVX-512", "maps AVX2", "Eigen": what provenance.json and `maps bench` record.
const char* f32_kernel_name(F32Kernel kernel);
// "avx512", "avx2", "eigen": the names MAPS_F32_KERNEL takes.
const std::vector<std::string>& f32_kernel_choices();
// Throws std::invalid_argument naming `where`, the value and the choices.
F32Kernel parse_f32_kernel(const std::string& name, const std::string& where);
// "" when this build has `kernel` and this CPU runs it; otherwise why not, as one phrase.
std::string f32_kernel_missing(F32Kernel kernel);
// The widest kernel this build has and this CPU runs.
F32Kernel best_f32_kernel();
// The kernel float32 products run: MAPS_F32_KERNEL's when set (it throws std::runtime_error naming the variable when
// the value is unknown or the CPU lacks it), else best_f32_kernel(); decided at the first call.
F32Kernel f32_kernel();
// Sets the kernel for the whole process and returns the previous one (tests, benchmarks). Throws
// std::runtime_error naming what is missing when the build or the CPU cannot run it.
F32Kernel set_f32_kernel(F32Kernel kernel);

// C [m, n] (row-major, `ldc` between rows) = A [m, k] B [k, n], or += when `accumulate`, on f32_kernel() (which must
// not be eigen: std::logic_error).
void gemm_f32(StridedF32 a, StridedF32 b, float* c, std::int64_t ldc, std::int64_t m, std::int64_t n, std::int64_t k,
              bool accumulate);

}  // namespace maps::ag::detail
