// matmul: 2-d, batched 3-d, and 3-d @ 2-d.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Dtype;
using ag::Shape;
using ag::Tensor;
using agtest::expect_grad_and_gradgrad;
using agtest::expect_throw_with;
using agtest::expect_values;
using agtest::kBothDtypes;
using agtest::kF32;
using agtest::kF64;
using agtest::randn64;
using agtest::tensor;

using Inputs = std::vector<Tensor>;

// Reference product with plain loops; a is [b?, n, k], b is [b?, k, m] (a missing batch dim is shared).
std::vector<double> matmul_ref(const Tensor& a, const Tensor& b, Shape* out_shape) {
  const bool a3 = a.dim() == 3;
  const bool b3 = b.dim() == 3;
  const std::int64_t batch = a3 ? a.size(0) : 1;
  const std::int64_t n = a.size(-2), k = a.size(-1), m = b.size(-1);
  const std::vector<double> av = a.to_vector(), bv = b.to_vector();
  std::vector<double> out(static_cast<std::size_t>(batch * n * m), 0.0);
  for (std::int64_t p = 0; p < batch; ++p)
    for (std::int64_t i = 0; i < n; ++i)
      for (std::int64_t j = 0; j < m; ++j) {
        double s = 0;
        for (std::int64_t q = 0; q < k; ++q) {
          s += av[static_cast<std::size_t>((a3 ? p * n * k : 0) + i * k + q)] *
               bv[static_cast<std::size_t>((b3 ? p * k * m : 0) + q * m + j)];
        }
        out[static_cast<std::size_t>(p * n * m + i * m + j)] = s;
      }
  *out_shape = a3 ? Shape{batch, n, m} : Shape{n, m};
  return out;
}

struct MatmulCase {
  Shape a;
  Shape b;
};

const std::vector<MatmulCase> kMatmulCases = {
    {{2, 3}, {3, 4}},       {{1, 3}, {3, 1}},       {{4, 1}, {1, 3}},       {{3, 3}, {3, 3}},  // 2-d
    {{2, 2, 3}, {2, 3, 2}}, {{3, 1, 2}, {3, 2, 2}}, {{1, 2, 2}, {1, 2, 3}},                    // batched
    {{2, 3, 2}, {2, 4}},    {{2, 2, 3}, {3, 1}},                                               // 3-d @ 2-d
};

std::string case_name(const MatmulCase& c) { return ag::to_string(c.a) + " @ " + ag::to_string(c.b); }

TEST(Matmul, ForwardMatchesReference) {
  std::uint64_t seed = 1;
  for (const MatmulCase& c : kMatmulCases) {
    for (Dtype dtype : kBothDtypes) {
      SCOPED_TRACE(case_name(c) + " " + ag::to_string(dtype));
      const Tensor a = randn64(c.a, seed++, false).to(dtype);
      const Tensor b = randn64(c.b, seed++, false).to(dtype);
      Shape out_shape;
      const std::vector<double> expected = matmul_ref(a, b, &out_shape);
      const Tensor y = ag::matmul(a, b);
      EXPECT_EQ(y.dtype(), dtype);
      expect_values(y, out_shape, expected, dtype == kF32 ? 1e-5 : 1e-12);
    }
  }
}

TEST(Matmul, HandComputed) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor a = tensor({1, 2, 3, 4, 5, 6}, {2, 3}, dtype);
    const Tensor b = tensor({7, 8, 9, 10, 11, 12}, {3, 2}, dtype);
    expect_values(ag::matmul(a, b), {2, 2}, {58, 64, 139, 154});
    // Two batches: the second is the first scaled by 2 on the left.
    const Tensor ab = tensor({1, 2, 3, 4, 5, 6, 2, 4, 6, 8, 10, 12}, {2, 2, 3}, dtype);
    expect_values(ag::matmul(ab, b), {2, 2, 2}, {58, 64, 139, 154, 116, 128, 278, 308});
    const Tensor bb = ag::stack({b, ag::mul(b, -1.0)}, 0);
    expect_values(ag::matmul(ab, bb), {2, 2, 2}, {58, 64, 139, 154, -116, -128, -278, -308});
  }
}

TEST(Matmul, LargeProductMatchesEigen) {
  ag::Generator gen(5);
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor a = ag::randn({64, 33}, gen, dtype);
    const Tensor b = ag::randn({33, 47}, gen, dtype);
    const Tensor y = ag::matmul(a, b);
    ASSERT_EQ(y.shape(), (Shape{64, 47}));
    const Eigen::MatrixXd expected = ag::to_eigen_double(a) * ag::to_eigen_double(b);
    const ag::RowMatrixD got = ag::to_eigen_double(y);
    EXPECT_LT((got - expected).cwiseAbs().maxCoeff(), dtype == kF32 ? 1e-4 : 1e-12);
  }
}

TEST(Matmul, GradcheckAllForms) {
  std::uint64_t seed = 100;
  for (const MatmulCase& c : kMatmulCases) {
    SCOPED_TRACE(case_name(c));
    auto f = [](const Inputs& in) { return ag::matmul(in[0], in[1]); };
    agtest::expect_gradcheck("matmul", f, {randn64(c.a, seed++), randn64(c.b, seed++)});
    // Only one side requiring grad.
    agtest::expect_gradcheck("matmul", f, {randn64(c.a, seed++, false), randn64(c.b, seed++)});
    agtest::expect_gradcheck("matmul", f, {randn64(c.a, seed++), randn64(c.b, seed++, false)});
  }
}

TEST(Matmul, GradgradcheckAllForms) {
  std::uint64_t seed = 200;
  for (const MatmulCase& c : kMatmulCases) {
    SCOPED_TRACE(case_name(c));
    auto f = [](const Inputs& in) { return ag::matmul(in[0], in[1]); };
    agtest::expect_gradgradcheck("matmul", f, {randn64(c.a, seed++), randn64(c.b, seed++)});
  }
  // x used on both sides: the Hessian has the cross terms.
  agtest::expect_gradgradcheck("matmul", [](const Inputs& in) { return ag::matmul(in[0], in[0]); },
                               {randn64({3, 3}, seed++)});
}

TEST(Matmul, HandComputedGradients) {
  const Tensor a = tensor({1, 2, 3, 4, 5, 6}, {2, 3}, kF64, true);
  const Tensor b = tensor({7, 8, 9, 10, 11, 12}, {3, 2}, kF64, true);
  ag::sum(ag::matmul(a, b)).backward();
  // dL/da = 1 @ b^T: each row holds b's row sums; dL/db = a^T @ 1: each row holds a's column sums.
  expect_values(a.grad(), {2, 3}, {15, 19, 23, 15, 19, 23});
  expect_values(b.grad(), {3, 2}, {5, 5, 7, 7, 9, 9});
  // 3-d @ 2-d sums the shared weight's gradient over the batch.
  const Tensor x = tensor({1, 2, 3, 4}, {2, 1, 2}, kF64, true);
  const Tensor w = tensor({1, 0, 0, 1}, {2, 2}, kF64, true);
  ag::sum(ag::matmul(x, w)).backward();
  expect_values(w.grad(), {2, 2}, {4, 4, 6, 6});
  expect_values(x.grad(), {2, 1, 2}, {1, 1, 1, 1});
}

TEST(Matmul, InnerSizeMismatchNamesOpAndShapes) {
  expect_throw_with([] { ag::matmul(ag::ones({2, 3}), ag::ones({4, 5})); }, agtest::names("matmul", {2, 3}, {4, 5}));
  expect_throw_with(
      [] {
        ag::matmul(ag::ones({2, 2, 3}), ag::ones({2, 2, 3}));
      },
      agtest::names("matmul", {2, 2, 3}, {2, 2, 3}));
  expect_throw_with(
      [] {
        ag::matmul(ag::ones({2, 2, 3}), ag::ones({2, 2}));
      },
      agtest::names("matmul", {2, 2, 3}, {2, 2}));
}

TEST(Matmul, BatchMismatchAndDtypeMismatchNameOp) {
  expect_throw_with(
      [] {
        ag::matmul(ag::ones({2, 2, 3}), ag::ones({3, 3, 2}));
      },
      agtest::names("matmul", {2, 2, 3}, {3, 3, 2}));
  expect_throw_with([] { ag::matmul(ag::ones({2, 3}, kF32), ag::ones({3, 2}, kF64)); }, {"matmul"});
  expect_throw_with([] { ag::matmul(ag::ones({2, 3, 4, 5}), ag::ones({5, 2})); }, {"matmul"});
}

TEST(Matmul, MlpCompositeGradgradcheck) {
  // sum((tanh(x @ w1 + b1) @ w2)^2): the shape of a small MLP's loss.
  auto mlp = [](const Inputs& in) {
    const Tensor h = ag::tanh(ag::matmul(in[0], in[1]) + in[2]);
    return ag::sum(ag::square(ag::matmul(h, in[3])));
  };
  expect_grad_and_gradgrad("mlp", mlp, {randn64({3, 2}, 1), randn64({2, 4}, 2), randn64({4}, 3), randn64({4, 2}, 4)});
}

TEST(Matmul, BatchedLinearCompositeGradgradcheck) {
  // M independent linears as one batched op (what ParallelLinear builds): x [M,n,k] @ w [M,k,m] + b [M,1,m].
  auto parallel = [](const Inputs& in) { return ag::sigmoid(ag::matmul(in[0], in[1]) + in[2]); };
  expect_grad_and_gradgrad("parallel linear", parallel,
                           {randn64({2, 3, 2}, 1), randn64({2, 2, 3}, 2), randn64({2, 1, 3}, 3)});
}

// ----- gemm: op(a) @ op(b) with optional transposes of the last two dims -----

struct GemmCase {
  Shape a;  // as stored, before the optional transpose
  Shape b;
  bool ta;
  bool tb;
};

const std::vector<GemmCase> kGemmCases = {
    {{2, 3}, {3, 4}, false, false},     {{3, 2}, {3, 4}, true, false},       {{2, 3}, {4, 3}, false, true},
    {{3, 2}, {4, 3}, true, true},       {{2, 3, 2}, {2, 3, 4}, true, false}, {{2, 2, 3}, {2, 4, 3}, false, true},
    {{2, 3, 2}, {2, 4, 3}, true, true}, {{2, 2, 3}, {4, 3}, false, true},    {{2, 2, 3}, {3, 4}, false, false},
};

std::string gemm_name(const GemmCase& c) {
  return ag::to_string(c.a) + (c.ta ? "^T" : "") + " @ " + ag::to_string(c.b) + (c.tb ? "^T" : "");
}

Tensor last_two_transposed(const Tensor& t, bool on) { return on ? ag::transpose(t, -2, -1) : t; }

TEST(Gemm, ForwardMatchesMatmulOfTransposes) {
  std::uint64_t seed = 1;
  for (const GemmCase& c : kGemmCases) {
    for (Dtype dtype : kBothDtypes) {
      SCOPED_TRACE(gemm_name(c) + " " + ag::to_string(dtype));
      const Tensor a = randn64(c.a, seed++, false).to(dtype);
      const Tensor b = randn64(c.b, seed++, false).to(dtype);
      Shape out_shape;
      const std::vector<double> expected =
          matmul_ref(last_two_transposed(a, c.ta), last_two_transposed(b, c.tb), &out_shape);
      const Tensor y = ag::gemm(a, b, c.ta, c.tb);
      EXPECT_EQ(y.dtype(), dtype);
      expect_values(y, out_shape, expected, dtype == kF32 ? 1e-5 : 1e-12);
    }
  }
}

TEST(Gemm, GradcheckAndGradgradcheck) {
  std::uint64_t seed = 100;
  for (const GemmCase& c : kGemmCases) {
    SCOPED_TRACE(gemm_name(c));
    auto f = [c](const Inputs& in) { return ag::gemm(in[0], in[1], c.ta, c.tb); };
    expect_grad_and_gradgrad("gemm", f, {randn64(c.a, seed++), randn64(c.b, seed++)});
    agtest::expect_gradcheck("gemm", f, {randn64(c.a, seed++, false), randn64(c.b, seed++)});
    agtest::expect_gradcheck("gemm", f, {randn64(c.a, seed++), randn64(c.b, seed++, false)});
  }
  // The same tensor on both sides: a^T a.
  agtest::expect_gradgradcheck("gemm", [](const Inputs& in) { return ag::gemm(in[0], in[0], true, false); },
                               {randn64({3, 2}, seed++)});
}

TEST(Gemm, InnerSizeMismatchNamesOpAndShapes) {
  expect_throw_with(
      [] {
        ag::gemm(ag::ones({2, 3}), ag::ones({4, 3}), false, false);
      },
      agtest::names("gemm", {2, 3}, {4, 3}));
  expect_throw_with(
      [] {
        ag::gemm(ag::ones({2, 3}), ag::ones({3, 4}), true, false);
      },
      agtest::names("gemm", {2, 3}, {3, 4}));
  expect_throw_with([] { ag::gemm(ag::ones({2, 2, 3}), ag::ones({3, 3, 4}), false, false); }, {"gemm"});
  expect_throw_with([] { ag::gemm(ag::ones({2, 3}, kF32), ag::ones({3, 2}, kF64), false, false); }, {"gemm"});
}

// ----- linear: x @ weight^T + bias -----

TEST(Linear, ForwardMatchesMatmulPlusBias) {
  std::uint64_t seed = 1;
  for (const Shape& x_shape : {Shape{3, 2}, Shape{1, 2}, Shape{2, 3, 2}}) {
    for (bool with_bias : {true, false}) {
      for (Dtype dtype : kBothDtypes) {
        SCOPED_TRACE(ag::to_string(x_shape) + (with_bias ? " with bias " : " without bias ") + ag::to_string(dtype));
        const Tensor x = randn64(x_shape, seed++, false).to(dtype);
        const Tensor w = randn64({4, 2}, seed++, false).to(dtype);
        const Tensor b = with_bias ? randn64({4}, seed++, false).to(dtype) : Tensor();
        Shape out_shape;
        std::vector<double> expected = matmul_ref(x, ag::transpose(w, 0, 1), &out_shape);
        if (with_bias) {
          for (std::size_t i = 0; i < expected.size(); ++i) expected[i] += b.at(static_cast<std::int64_t>(i % 4));
        }
        const Tensor y = ag::linear(x, w, b);
        EXPECT_EQ(y.dtype(), dtype);
        expect_values(y, out_shape, expected, dtype == kF32 ? 1e-5 : 1e-12);
      }
    }
  }
}

TEST(Linear, HandComputed) {
  const Tensor x = tensor({1, 2, 3, 4}, {2, 2}, kF64, true);
  const Tensor w = tensor({1, 0, 1, 1, 0, -1}, {3, 2}, kF64, true);
  const Tensor b = tensor({10, 20, 30}, {3}, kF64, true);
  const Tensor y = ag::linear(x, w, b);
  expect_values(y, {2, 3}, {11, 23, 28, 13, 27, 26});
  ag::sum(y).backward();
  expect_values(x.grad(), {2, 2}, {2, 0, 2, 0});
  expect_values(w.grad(), {3, 2}, {4, 6, 4, 6, 4, 6});
  expect_values(b.grad(), {3}, {2, 2, 2});
}

TEST(Linear, GradcheckAndGradgradcheck) {
  std::uint64_t seed = 200;
  auto with_bias = [](const Inputs& in) { return ag::linear(in[0], in[1], in[2]); };
  auto without_bias = [](const Inputs& in) { return ag::linear(in[0], in[1]); };
  for (const Shape& x_shape : {Shape{3, 2}, Shape{2, 3, 2}}) {
    SCOPED_TRACE(ag::to_string(x_shape));
    expect_grad_and_gradgrad("linear", with_bias,
                             {randn64(x_shape, seed++), randn64({4, 2}, seed++), randn64({4}, seed++)});
    expect_grad_and_gradgrad("linear", without_bias, {randn64(x_shape, seed++), randn64({4, 2}, seed++)});
    // Fixed input, trainable weight and bias, as in a first layer.
    agtest::expect_gradcheck("linear", with_bias,
                             {randn64(x_shape, seed++, false), randn64({4, 2}, seed++), randn64({4}, seed++)});
  }
  // A tanh MLP built from linears, second order.
  auto mlp = [](const Inputs& in) {
    return ag::sum(ag::square(ag::linear(ag::tanh(ag::linear(in[0], in[1], in[2])), in[3])));
  };
  expect_grad_and_gradgrad(
      "linear mlp", mlp,
      {randn64({3, 2}, seed++), randn64({4, 2}, seed++), randn64({4}, seed++), randn64({2, 4}, seed++)});
}

TEST(Linear, ShapeErrorsNameOp) {
  expect_throw_with([] { ag::linear(ag::ones({3, 2}), ag::ones({4, 3})); }, agtest::names("linear", {3, 2}, {4, 3}));
  expect_throw_with([] { ag::linear(ag::ones({3, 2}), ag::ones({4, 2}), ag::ones({3})); }, {"linear", "[3]"});
  expect_throw_with([] { ag::linear(ag::ones({3, 2}, kF64), ag::ones({4, 2}, kF32)); }, {"linear"});
}

}  // namespace
