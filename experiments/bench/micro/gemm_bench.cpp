// The float32 products of a MAPS training step, and the 1024^3 reference, in maps's own kernel (ag::gemm, which
// runs autograd/gemm_f32.h), in its bfloat16 kernel (autograd/gemm_bf16.h: operands rounded to bfloat16, sums in
// float32; skipped on a CPU without AVX512-BF16) and in Eigen's GEMM on the same operands, one thread. Counters:
// GFLOP/s.
// Run: build/bin/maps_bench --benchmark_filter=Gemm
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "autograd/autograd.h"
#include "autograd/gemm_bf16.h"

namespace {

using namespace maps;
using RowMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// C [m, n] = op(A) op(B) with an inner size k; the flags say which operand is stored transposed.
struct Shape {
  std::int64_t m, n, k;
  bool ta, tb;
};

// The step's products at MT10's shapes (320 states, hidden 128, 3520 selector rows), the reference, then at
// Gravity's (640 states, 17 observations, 6 actions: the shapes that take most of its bf16 step).
constexpr int kShapeCount = 13;
Shape shape_of(std::int64_t index) {
  constexpr Shape kShapes[kShapeCount] = {
      {320, 128, 128, false, false},     // a module layer forward: X W
      {320, 128, 128, false, true},      // its input gradient: G W^T
      {128, 128, 320, true, false},      // its weight gradient: X^T G
      {3520, 128, 128, false, true},     // the selector's hidden layer forward: H W^T
      {128, 128, 3520, true, false},     // its weight gradient
      {320, 4, 128, false, false},       // a head block: v W
      {3520, 10, 128, false, true},      // the selector's scores
      {1024, 1024, 1024, false, false},  // the ceiling reference (index 7, as docs/autograd.md runs it)
      {640, 128, 128, false, true},      // Gravity: a module layer's input gradient G W^T
      {128, 128, 640, true, false},      // its weight gradient X^T G
      {640, 128, 6, false, true},        // the head's input gradient (6 actions)
      {640, 128, 17, false, false},      // the first layer forward (17 observations)
      {17, 128, 640, true, false},       // its weight gradient
  };
  return kShapes[index];
}

void set_counters(benchmark::State& state, const Shape& s, const std::string& kernel) {
  state.counters["GFLOP/s"] =
      benchmark::Counter(2.0 * static_cast<double>(s.m * s.n * s.k) * static_cast<double>(state.iterations()) * 1e-9,
                         benchmark::Counter::kIsRate);
  state.SetLabel(std::to_string(s.m) + "x" + std::to_string(s.n) + "x" + std::to_string(s.k) + (s.ta ? " A^T" : "") +
                 (s.tb ? " B^T" : "") + " (" + kernel + ")");
}

// ag::gemm's float32 kernel: maps's own where the build has AVX-512, else Eigen's (the label says which).
void BM_GemmOwn(benchmark::State& state) {
  const Shape s = shape_of(state.range(0));
  ag::set_num_threads(1);
  ag::Generator gen(0);
  const ag::Tensor a = ag::randn(s.ta ? ag::Shape{s.k, s.m} : ag::Shape{s.m, s.k}, gen);
  const ag::Tensor b = ag::randn(s.tb ? ag::Shape{s.n, s.k} : ag::Shape{s.k, s.n}, gen);
  ag::NoGradGuard no_grad;
  for (auto _ : state) {
    ag::Tensor c = ag::gemm(a, b, s.ta, s.tb);
    benchmark::DoNotOptimize(c.data<float>());
  }
  set_counters(state, s, ag::float32_gemm_kernel());
}

// The bfloat16 kernel on the same products (operands rounded as it packs them, as a training step in bf16 would).
void BM_GemmBf16(benchmark::State& state) {
  if (!ag::detail::cpu_has_avx512_bf16()) {
    state.SkipWithError(("this CPU lacks " + ag::detail::avx512_bf16_missing()).c_str());
    return;
  }
  const Shape s = shape_of(state.range(0));
  const RowMatrixF a = s.ta ? RowMatrixF::Random(s.k, s.m) : RowMatrixF::Random(s.m, s.k);
  const RowMatrixF b = s.tb ? RowMatrixF::Random(s.n, s.k) : RowMatrixF::Random(s.k, s.n);
  RowMatrixF c(s.m, s.n);
  const ag::detail::StridedF32 sa =
      s.ta ? ag::detail::StridedF32{a.data(), 1, s.m} : ag::detail::StridedF32{a.data(), s.k, 1};
  const ag::detail::StridedF32 sb =
      s.tb ? ag::detail::StridedF32{b.data(), 1, s.k} : ag::detail::StridedF32{b.data(), s.n, 1};
  for (auto _ : state) {
    ag::detail::gemm_bf16(sa, sb, c.data(), s.n, s.m, s.n, s.k, false);
    benchmark::DoNotOptimize(c.data());
  }
  set_counters(state, s, "maps AVX512-BF16");
}

void BM_GemmEigen(benchmark::State& state) {
  const Shape s = shape_of(state.range(0));
  const RowMatrixF a = s.ta ? RowMatrixF::Random(s.k, s.m) : RowMatrixF::Random(s.m, s.k);
  const RowMatrixF b = s.tb ? RowMatrixF::Random(s.n, s.k) : RowMatrixF::Random(s.k, s.n);
  RowMatrixF c(s.m, s.n);
  for (auto _ : state) {
    if (s.ta && s.tb) {
      c.noalias() = a.transpose() * b.transpose();
    } else if (s.ta) {
      c.noalias() = a.transpose() * b;
    } else if (s.tb) {
      c.noalias() = a * b.transpose();
    } else {
      c.noalias() = a * b;
    }
    benchmark::DoNotOptimize(c.data());
  }
  set_counters(state, s, "Eigen");
}

BENCHMARK(BM_GemmOwn)->DenseRange(0, kShapeCount - 1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_GemmBf16)->DenseRange(0, kShapeCount - 1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_GemmEigen)->DenseRange(0, kShapeCount - 1)->Unit(benchmark::kMicrosecond);

}  // namespace
