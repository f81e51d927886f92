// gram_schmidt: MOORE's per-sample orthonormalisation of k vectors, and its first and second derivatives.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Shape;
using ag::Tensor;
using agtest::expect_grad_and_gradgrad;
using agtest::expect_throw_with;
using agtest::expect_values;
using agtest::kBothDtypes;
using agtest::randn64;
using agtest::tensor;

// The value at [i, s, f] of a [k, n, F] tensor's row-major values.
double at(const std::vector<double>& values, const Shape& shape, std::int64_t i, std::int64_t s, std::int64_t f) {
  return values[static_cast<std::size_t>((i * shape[1] + s) * shape[2] + f)];
}

TEST(GramSchmidt, HandComputed) {
  // One sample: v1 = (3, 4, 0) -> (0.6, 0.8, 0); v2 = (1, 0, 2): minus <v2, u1> u1 = 0.6 (0.6, 0.8, 0) leaves
  // (0.64, -0.48, 2), of norm sqrt(0.4096 + 0.2304 + 4) = sqrt(4.64).
  for (const auto dtype : kBothDtypes) {
    const Tensor v = tensor({3, 4, 0, 1, 0, 2}, {2, 1, 3}, dtype);
    const double r = std::sqrt(4.64);
    expect_values(ag::gram_schmidt(v), {2, 1, 3}, {0.6, 0.8, 0, 0.64 / r, -0.48 / r, 2 / r},
                  dtype == ag::Dtype::Float32 ? 1e-6 : 1e-14);
  }
}

TEST(GramSchmidt, EverySampleOrthonormalAndSpanningItsInputsInOrder) {
  const Shape shape{4, 6, 7};
  const Tensor v = randn64(shape, 11, false);
  const auto u = ag::gram_schmidt(v).to_vector();
  const auto x = v.to_vector();
  for (std::int64_t s = 0; s < shape[1]; ++s)
    for (std::int64_t i = 0; i < shape[0]; ++i) {
      for (std::int64_t j = 0; j <= i; ++j) {
        double dot = 0, v_dot_u = 0;
        for (std::int64_t f = 0; f < shape[2]; ++f) {
          dot += at(u, shape, i, s, f) * at(u, shape, j, s, f);
          v_dot_u += at(x, shape, j, s, f) * at(u, shape, i, s, f);
        }
        EXPECT_NEAR(dot, i == j ? 1.0 : 0.0, 1e-12) << "sample " << s << " vectors " << i << ", " << j;
        // u_i is orthogonal to every earlier input (v_j, j < i) and has a positive part along its own.
        if (j < i) {
          EXPECT_NEAR(v_dot_u, 0.0, 1e-12) << "sample " << s << " u_" << i << " . v_" << j;
        } else {
          EXPECT_GT(v_dot_u, 0.0) << "sample " << s << " u_" << i << " . v_" << i;
        }
      }
    }
}

TEST(GramSchmidt, Float32AgreesWithFloat64) {
  const Tensor v = randn64({3, 50, 16}, 5, false);
  agtest::expect_close(ag::gram_schmidt(v.to(ag::Dtype::Float32)).to(ag::Dtype::Float64), ag::gram_schmidt(v), 1e-5);
}

TEST(GramSchmidt, GradcheckAndGradgradcheck) {
  // k < F, k = F (a full basis), k = 1 (a normalisation), and several samples.
  for (const Shape& shape : {Shape{3, 2, 5}, Shape{3, 1, 3}, Shape{1, 4, 3}, Shape{2, 3, 2}}) {
    const Tensor v = randn64(shape, 21);
    expect_grad_and_gradgrad("gram_schmidt " + ag::to_string(shape),
                             [](const std::vector<Tensor>& in) { return ag::gram_schmidt(in[0]); }, {v});
  }
}

// The backward runs as one kernel pass when no graph of the gradient is asked for (training) and as ops with
// create_graph; both give the same gradient.
TEST(GramSchmidt, KernelBackwardAgreesWithTheOpsBackward) {
  for (const Shape& shape : {Shape{4, 7, 9}, Shape{3, 5, 3}, Shape{1, 2, 4}}) {
    const Tensor v = randn64(shape, 41);
    const Tensor weights = randn64(shape, 42, false);
    const Tensor loss = ag::sum(ag::mul(ag::gram_schmidt(v), weights));
    const Tensor kernel = ag::grad({loss}, {v}, {}, /*retain_graph=*/true, /*create_graph=*/false)[0];
    const Tensor ops = ag::grad({loss}, {v}, {}, /*retain_graph=*/true, /*create_graph=*/true)[0];
    agtest::expect_close(kernel, ops.detach(), 1e-12);
  }
}

TEST(GramSchmidt, ThroughAWeightedSumAndTanhLikeMoore) {
  // MOORE's use: tanh(sum_i w_i u_i) with task weights w [k]; both inputs differentiable.
  const Tensor v = randn64({3, 4, 5}, 31);
  const Tensor w = randn64({3, 1, 1}, 32);
  expect_grad_and_gradgrad(
      "tanh(sum_i w_i gram_schmidt(v)_i)",
      [](const std::vector<Tensor>& in) { return ag::tanh(ag::sum(ag::mul(ag::gram_schmidt(in[0]), in[1]), {0})); },
      {v, w});
}

TEST(GramSchmidt, BadShapesNameTheOpAndTheShape) {
  expect_throw_with([] { ag::gram_schmidt(randn64({3, 4}, 1, false)); }, {"gram_schmidt", "[k, n, F]", "[3, 4]"});
  expect_throw_with(
      [] {
        ag::gram_schmidt(randn64({5, 2, 3}, 1, false));
      },
      {"gram_schmidt", "5 vectors", "width 3", "k <= F"});
  expect_throw_with([] { ag::gram_schmidt(Tensor()); }, {"gram_schmidt"});
}

}  // namespace
