// The products' precision (autograd/matmul_precision.h, issue 44): the setting's names, scope and threads, the
// refusal on a CPU without AVX512-BF16, and the bf16 path's error pinned against float64: forward values and
// first- and second-order gradients of layers (matmul, linear, mlp, parallel_linear, parallel_mlp) at documented
// tolerances, narrow outputs left in float32 bit for bit. Tests that need the instructions are skipped, saying
// why, on a CPU without them.

#include "autograd/matmul_precision.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "autograd/autograd.h"
#include "autograd/gemm_bf16.h"

namespace {

namespace ag = maps::ag;
using ag::MatmulPrecision;
using ag::Tensor;

#define SKIP_WITHOUT_BF16()               \
  if (!ag::detail::cpu_has_avx512_bf16()) \
  GTEST_SKIP() << "this CPU lacks " << ag::detail::avx512_bf16_missing() << ": bf16 products cannot run here"

// The tolerance the docs state (docs/performance.md, "bfloat16"): each operand of a product is rounded to bfloat16
// (relative error at most 2^-9) and the sums are float32, so a product's error is at most about 2^-8 of sum |a||b|;
// through a few layers and their gradients the relative (Frobenius) error of a result stays within 2^-6 for the
// well-scaled values here (measured 0.002-0.006). float32 products stay within 1e-5 of float64.
constexpr double kBf16Tolerance = 1.0 / 64;
constexpr double kFloat32Tolerance = 1e-5;

double relative_error(const Tensor& approx, const Tensor& exact) {
  const ag::RowMatrixD a = ag::to_eigen_double(approx.to(ag::Dtype::Float64).reshape({-1, 1}));
  const ag::RowMatrixD e = ag::to_eigen_double(exact.reshape({-1, 1}));
  return (a - e).norm() / std::max(e.norm(), 1e-300);
}

TEST(MatmulPrecision, NamesParseAndAnUnknownOneIsRefusedWithTheChoices) {
  EXPECT_EQ(ag::to_string(MatmulPrecision::float32), "float32");
  EXPECT_EQ(ag::to_string(MatmulPrecision::bf16), "bf16");
  for (const std::string& name : ag::matmul_precision_names())
    EXPECT_EQ(ag::to_string(ag::parse_matmul_precision(name)), name);
  try {
    ag::parse_matmul_precision("fp16");
    FAIL() << "fp16 was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'fp16'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("float32, bf16"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ag::matmul_precision_missing(MatmulPrecision::float32), "");
}

TEST(MatmulPrecision, ACpuWithoutTheInstructionsRefusesBf16NamingWhatItLacks) {
  const std::string missing = ag::matmul_precision_missing(MatmulPrecision::bf16);
  EXPECT_EQ(missing.empty(), ag::detail::cpu_has_avx512_bf16()) << missing;
  EXPECT_EQ(ag::matmul_precision_refusal(MatmulPrecision::float32, "any CPU"), "");
  const std::string refusal = ag::matmul_precision_refusal(MatmulPrecision::bf16, "the CPU's model");
  EXPECT_EQ(refusal.empty(), missing.empty()) << refusal;
  if (!missing.empty()) {
    EXPECT_EQ(refusal, "needs a CPU with AVX512-BF16, and this one (the CPU's model) lacks " + missing);
  }
  if (missing.empty()) {
    const ag::MatmulPrecisionGuard guard(MatmulPrecision::bf16);
    EXPECT_EQ(ag::matmul_precision(), MatmulPrecision::bf16);
  } else {
    try {
      ag::set_matmul_precision(MatmulPrecision::bf16);
      FAIL() << "bf16 was set on a CPU lacking " << missing;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    }
    EXPECT_EQ(ag::matmul_precision(), MatmulPrecision::float32);
  }
}

TEST(MatmulPrecision, TheGuardRestoresANewThreadStartsInFloat32AndOpThreadsFollowTheCaller) {
  SKIP_WITHOUT_BF16();
  EXPECT_EQ(ag::matmul_precision(), MatmulPrecision::float32);
  {
    const ag::MatmulPrecisionGuard guard(MatmulPrecision::bf16);
    EXPECT_EQ(ag::matmul_precision(), MatmulPrecision::bf16);
    MatmulPrecision seen_by_new_thread = MatmulPrecision::bf16;
    std::thread([&] { seen_by_new_thread = ag::matmul_precision(); }).join();
    EXPECT_EQ(seen_by_new_thread, MatmulPrecision::float32);
    const int saved_threads = ag::num_threads();
    ag::set_num_threads(2);
    std::vector<int> bf16_ranges(8, 0);
    ag::parallel_for_ranges(8, 8, [&](std::int64_t range, std::int64_t, std::int64_t) {
      bf16_ranges[range] = ag::matmul_precision() == MatmulPrecision::bf16;
    });
    ag::set_num_threads(saved_threads);
    for (int r = 0; r < 8; ++r) EXPECT_EQ(bf16_ranges[r], 1) << "range " << r;
  }
  EXPECT_EQ(ag::matmul_precision(), MatmulPrecision::float32);
}

// y = tanh(x W1^T + b1) W2 (a layer and a wide product) and its gradients, in float64 and in float32 at the current
// precision; rows x in -> hidden -> out.
struct TwoLayers {
  Tensor x, w1, b1, w2;
};

TwoLayers two_layers(ag::Dtype dtype, std::int64_t rows, std::int64_t in, std::int64_t hidden, std::int64_t out) {
  ag::Generator gen(11);
  TwoLayers layers{ag::randn({rows, in}, gen, ag::Dtype::Float64),
                   ag::randn({hidden, in}, gen, ag::Dtype::Float64) * (1.0 / std::sqrt(double(in))),
                   ag::randn({hidden}, gen, ag::Dtype::Float64) * 0.1,
                   ag::randn({hidden, out}, gen, ag::Dtype::Float64) * (1.0 / std::sqrt(double(hidden)))};
  for (Tensor* t : {&layers.x, &layers.w1, &layers.b1, &layers.w2}) *t = t->to(dtype).detach().requires_grad_();
  return layers;
}

std::vector<Tensor> value_and_gradients(const TwoLayers& l) {
  const Tensor y = ag::matmul(ag::linear(l.x, l.w1, l.b1, ag::Fused::Tanh), l.w2);
  // A fixed, uneven weighting of the outputs, so no gradient is a plain sum.
  const Tensor loss = ag::sum(y * ag::tanh(y.detach() + 0.5));
  std::vector<Tensor> results{y};
  for (const Tensor& g : ag::grad({loss}, {l.x, l.w1, l.b1, l.w2})) results.push_back(g);
  return results;
}

TEST(MatmulPrecision, Bf16ValuesAndGradientsStayWithinTheDocumentedToleranceOfFloat64) {
  SKIP_WITHOUT_BF16();
  const std::vector<Tensor> exact = value_and_gradients(two_layers(ag::Dtype::Float64, 96, 40, 128, 64));
  const TwoLayers f32 = two_layers(ag::Dtype::Float32, 96, 40, 128, 64);
  const std::vector<Tensor> float32 = value_and_gradients(f32);
  std::vector<Tensor> bf16;
  {
    const ag::MatmulPrecisionGuard guard(MatmulPrecision::bf16);
    bf16 = value_and_gradients(f32);
  }
  const char* names[] = {"y", "dx", "dW1", "db1", "dW2"};
  for (std::size_t i = 0; i < exact.size(); ++i) {
    const double e32 = relative_error(float32[i], exact[i]), e16 = relative_error(bf16[i], exact[i]);
    EXPECT_LT(e32, kFloat32Tolerance) << names[i];
    EXPECT_LT(e16, kBf16Tolerance) << names[i];
    // The bf16 kernel ran: its rounding shows, some thousand times float32's error.
    EXPECT_GT(e16, 10 * e32) << names[i] << ": bf16 no less exact than float32; was the bfloat16 kernel run?";
    std::cout << names[i] << ": relative error float32 " << e32 << ", bf16 " << e16 << "\n";
  }
}

TEST(MatmulPrecision, Bf16SecondOrderGradientsStayWithinTheDocumentedTolerance) {
  SKIP_WITHOUT_BF16();
  // MAML's meta-gradient: the gradient of a loss after one inner step, through the inner step's gradient.
  auto meta_gradient = [](ag::Dtype dtype) {
    const TwoLayers l = two_layers(dtype, 64, 32, 64, 32);
    const Tensor inner = ag::sum(ag::tanh(ag::matmul(ag::linear(l.x, l.w1, l.b1, ag::Fused::Tanh), l.w2)));
    const Tensor dw2 = ag::grad({inner}, {l.w2}, {}, std::nullopt, /*create_graph=*/true)[0];
    const Tensor adapted = l.w2 - dw2 * 0.1;
    const Tensor outer = ag::sum(ag::matmul(ag::linear(l.x, l.w1, l.b1, ag::Fused::Tanh), adapted) * 0.3);
    return ag::grad({outer}, {l.w1, l.w2});
  };
  const std::vector<Tensor> exact = meta_gradient(ag::Dtype::Float64);
  std::vector<Tensor> bf16;
  {
    const ag::MatmulPrecisionGuard guard(MatmulPrecision::bf16);
    bf16 = meta_gradient(ag::Dtype::Float32);
  }
  for (std::size_t i = 0; i < exact.size(); ++i)
    EXPECT_LT(relative_error(bf16[i], exact[i]), kBf16Tolerance) << (i == 0 ? "dW1" : "dW2");
}

TEST(MatmulPrecision, ParallelLayersFollowThePrecisionWithinTheTolerance) {
  SKIP_WITHOUT_BF16();
  // MAPS's modules: M parallel layers on one shared input, then a second parallel layer.
  auto modules = [](ag::Dtype dtype) {
    ag::Generator gen(5);
    const Tensor x = ag::randn({80, 24}, gen, ag::Dtype::Float64).to(dtype).detach().requires_grad_();
    const Tensor w1 = (ag::randn({4, 24, 64}, gen, ag::Dtype::Float64) * 0.2).to(dtype).detach().requires_grad_();
    const Tensor w2 = (ag::randn({4, 64, 32}, gen, ag::Dtype::Float64) * 0.125).to(dtype).detach().requires_grad_();
    const Tensor y = ag::parallel_mlp(x, {w1, w2}, {}, ag::Fused::Tanh);
    const Tensor z = ag::parallel_linear(y, w2.transpose(1, 2), Tensor(), ag::Fused::Tanh);
    std::vector<Tensor> results{z};
    for (const Tensor& g : ag::grad({ag::sum(z * z)}, {x, w1, w2})) results.push_back(g);
    return results;
  };
  const std::vector<Tensor> exact = modules(ag::Dtype::Float64);
  std::vector<Tensor> bf16;
  {
    const ag::MatmulPrecisionGuard guard(MatmulPrecision::bf16);
    bf16 = modules(ag::Dtype::Float32);
  }
  const char* names[] = {"z", "dx", "dW1", "dW2"};
  for (std::size_t i = 0; i < exact.size(); ++i)
    EXPECT_LT(relative_error(bf16[i], exact[i]), kBf16Tolerance) << names[i];
}

TEST(MatmulPrecision, NarrowOutputsStayFloat32BitForBitAndFloat64IsNeverRounded) {
  SKIP_WITHOUT_BF16();
  ag::Generator gen(2);
  const Tensor a = ag::randn({200, 128}, gen), b = ag::randn({128, 6}, gen);
  const Tensor a64 = a.to(ag::Dtype::Float64), wide64 = ag::randn({128, 64}, gen, ag::Dtype::Float64);
  const Tensor narrow32 = ag::matmul(a, b), exact64 = ag::matmul(a64, wide64);
  const ag::MatmulPrecisionGuard guard(MatmulPrecision::bf16);
  EXPECT_TRUE(ag::to_eigen_float(ag::matmul(a, b)) == ag::to_eigen_float(narrow32));
  EXPECT_TRUE(ag::to_eigen_double(ag::matmul(a64, wide64)) == ag::to_eigen_double(exact64));
}

}  // namespace
