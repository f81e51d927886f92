// Layer ops (linear and parallel_linear with a fused tanh, tanh_backward), the GEMM kernel's paths (inner blocks,
// narrow outputs, the split across threads), parallel_for and the storage pool.

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "autograd/storage_pool.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Dtype;
using ag::Fused;
using ag::Shape;
using ag::Tensor;
using agtest::expect_grad_and_gradgrad;
using agtest::expect_throw_with;
using agtest::kF64;
using agtest::randn64;

using Inputs = std::vector<Tensor>;

// Restores one op thread when a test that changed it ends, whatever happens.
struct ThreadsGuard {
  explicit ThreadsGuard(int threads) { ag::set_num_threads(threads); }
  ~ThreadsGuard() { ag::set_num_threads(1); }
};

void expect_close(const Tensor& actual, const Tensor& expected, double tol, const std::string& what) {
  ASSERT_EQ(ag::to_string(actual.shape()), ag::to_string(expected.shape())) << what;
  const std::vector<double> a = actual.to_vector(), e = expected.to_vector();
  for (std::size_t i = 0; i < a.size(); ++i)
    ASSERT_NEAR(a[i], e[i], tol * (1.0 + std::abs(e[i]))) << what << " at flat index " << i;
}

// parallel_linear from ops it fuses: per member x_m @ w_m + b_m, then the activation.
Tensor parallel_linear_reference(const Tensor& x, const Tensor& w, const Tensor& b, Fused act) {
  const Tensor input = x.dim() == 2 ? ag::expand(x, {w.size(0), x.size(0), x.size(1)}) : x;
  Tensor y = ag::matmul(input, w);
  if (b.defined()) y = y + b;
  return act == Fused::Tanh ? ag::tanh(y) : y;
}

TEST(TanhBackward, ValuesAndBothDerivatives) {
  const Tensor g = randn64({3, 4}, 1), y = ag::tanh(randn64({3, 4}, 2, false)).detach().requires_grad_();
  expect_close(ag::tanh_backward(g, y), g * (1.0 - y * y), 1e-14, "g (1 - y^2)");
  expect_grad_and_gradgrad("tanh_backward", [](const Inputs& in) { return ag::tanh_backward(in[0], in[1]); }, {g, y});
}

TEST(TanhBackward, RejectsMismatchedInputs) {
  expect_throw_with([] { ag::tanh_backward(ag::zeros({2, 3}), ag::zeros({3, 2})); }, {"same shape"});
  expect_throw_with([] { ag::tanh_backward(ag::zeros({2}), ag::zeros({2}, kF64)); }, {"dtypes differ"});
}

TEST(LinearTanh, EqualsLinearThenTanhAndDifferentiates) {
  // 40 rows: more than one block of 16 rows.
  for (const Shape& x_shape : {Shape{40, 5}, Shape{2, 3, 5}}) {
    const Tensor x = randn64(x_shape, 3), w = randn64({4, 5}, 4), b = randn64({4}, 5);
    expect_close(ag::linear(x, w, b, Fused::Tanh), ag::tanh(ag::linear(x, w, b)), 1e-14, "linear tanh");
    expect_grad_and_gradgrad("linear tanh",
                             [](const Inputs& in) { return ag::linear(in[0], in[1], in[2], Fused::Tanh); }, {x, w, b});
    expect_grad_and_gradgrad("linear tanh, no bias",
                             [](const Inputs& in) { return ag::linear(in[0], in[1], Tensor(), Fused::Tanh); }, {x, w});
  }
}

TEST(ParallelLinear, EqualsItsReferenceForEveryInputBiasAndActivation) {
  for (const bool shared : {false, true}) {
    for (const bool bias : {false, true}) {
      for (const Fused act : {Fused::None, Fused::Tanh}) {
        const std::string what =
            std::string(shared ? "shared" : "batched") + (bias ? ", bias" : "") + (act == Fused::Tanh ? ", tanh" : "");
        const Tensor x = shared ? randn64({6, 3}, 10) : randn64({2, 6, 3}, 10);
        const Tensor w = randn64({2, 3, 4}, 11);
        const Tensor b = bias ? randn64({2, 1, 4}, 12) : Tensor();
        expect_close(ag::parallel_linear(x, w, b, act), parallel_linear_reference(x, w, b, act), 1e-13, what);
        Inputs inputs{x, w};
        if (bias) inputs.push_back(b);
        expect_grad_and_gradgrad(
            "parallel_linear " + what,
            [act](const Inputs& in) {
              return ag::parallel_linear(in[0], in[1], in.size() > 2 ? in[2] : Tensor(), act);
            },
            inputs);
      }
    }
  }
}

TEST(ParallelLinear, FastGradientsEqualTheRecordedOnes) {
  // backward() without create_graph takes the fused per-layer path; create_graph takes the path made of ops.
  const Tensor x = randn64({3, 20, 7}, 20), w = randn64({3, 7, 5}, 21), b = randn64({3, 1, 5}, 22);
  const Tensor g = randn64({3, 20, 5}, 23, false);
  const Tensor y = ag::parallel_linear(x, w, b, Fused::Tanh);
  const std::vector<Tensor> fast = ag::grad({y}, {x, w, b}, {g}, true, false);
  const std::vector<Tensor> recorded = ag::grad({y}, {x, w, b}, {g}, true, true);
  for (std::size_t i = 0; i < fast.size(); ++i)
    expect_close(fast[i], recorded[i].detach(), 1e-12, "gradient " + std::to_string(i));
}

TEST(ParallelLinear, RejectsShapesThatDoNotFit) {
  const Tensor w = ag::zeros({2, 3, 4});
  expect_throw_with([&] { ag::parallel_linear(ag::zeros({5, 4}), w); }, {"does not fit weight"});
  expect_throw_with([&] { ag::parallel_linear(ag::zeros({3, 5, 3}), w); }, {"does not fit weight"});
  expect_throw_with([&] { ag::parallel_linear(ag::zeros({5, 3}), ag::zeros({3, 4})); }, {"[members, in, out]"});
  expect_throw_with([&] { ag::parallel_linear(ag::zeros({5, 3}), w, ag::zeros({2, 4})); }, {"expected [2, 1, 4]"});
}

TEST(LinearAndParallelLinear, FastGradientsEqualTheRecordedOnesOverSeveralRowBlocksAndThreads) {
  // 1100 rows: three blocks of 512 rows; products above the size the kernels split, so on two threads the weight
  // and bias sums come from two ranges.
  for (const int threads : {1, 2}) {
    ThreadsGuard guard(threads);
    for (const Fused act : {Fused::None, Fused::Tanh}) {
      const Tensor x = randn64({1100, 64}, 50), w = randn64({64, 64}, 51), b = randn64({64}, 52);
      const Tensor g = randn64({1100, 64}, 53, false);
      const Tensor y = ag::linear(x, w, b, act);
      const std::vector<Tensor> fast = ag::grad({y}, {x, w, b}, {g}, true, false);
      const std::vector<Tensor> recorded = ag::grad({y}, {x, w, b}, {g}, true, true);
      for (std::size_t i = 0; i < fast.size(); ++i)
        expect_close(fast[i], recorded[i].detach(), 1e-11,
                     "linear gradient " + std::to_string(i) + " on " + std::to_string(threads) + " thread(s)");
      const Tensor px = randn64({3, 1100, 32}, 54), pw = randn64({3, 32, 32}, 55), pb = randn64({3, 1, 32}, 56);
      const Tensor pg = randn64({3, 1100, 32}, 57, false);
      const Tensor py = ag::parallel_linear(px, pw, pb, act);
      const std::vector<Tensor> pfast = ag::grad({py}, {px, pw, pb}, {pg}, true, false);
      const std::vector<Tensor> precorded = ag::grad({py}, {px, pw, pb}, {pg}, true, true);
      for (std::size_t i = 0; i < pfast.size(); ++i)
        expect_close(pfast[i], precorded[i].detach(), 1e-11,
                     "parallel_linear gradient " + std::to_string(i) + " on " + std::to_string(threads) + " thread(s)");
    }
  }
}

TEST(GatherAdd, SumsTheChosenRowsAndDifferentiates) {
  const Tensor a = randn64({3, 4}, 60), b = randn64({2, 4}, 61);
  const std::vector<std::int64_t> a_rows = {0, 2, 2, 1, 0}, b_rows = {1, 1, 0, 0, 1};
  const Tensor plain = ag::index_select(a, a_rows) + ag::index_select(b, b_rows);
  expect_close(ag::gather_add(a, a_rows, b, b_rows), plain, 1e-15, "gather_add");
  expect_close(ag::gather_add(a, a_rows, b, b_rows, Fused::Tanh), ag::tanh(plain), 1e-15, "gather_add tanh");
  for (const Fused act : {Fused::None, Fused::Tanh})
    expect_grad_and_gradgrad(
        "gather_add", [&](const Inputs& in) { return ag::gather_add(in[0], a_rows, in[1], b_rows, act); }, {a, b});
}

// The unrecorded scatter (each range of rows into tables of its own, summed after) against the recorded ops, on
// one thread and two, with enough rows to split (600 rows of 64: ranges from 256 rows) and repeated indices.
TEST(GatherAdd, FastGradientsEqualTheRecordedOnesOnOneAndTwoThreads) {
  const Tensor a = randn64({7, 64}, 62), b = randn64({50, 64}, 63);
  std::vector<std::int64_t> a_rows, b_rows;
  for (std::int64_t r = 0; r < 600; ++r) {
    a_rows.push_back(r % 7);
    b_rows.push_back((r * 13) % 50);
  }
  const Tensor g = randn64({600, 64}, 64, false);
  for (const int threads : {1, 2}) {
    ThreadsGuard guard(threads);
    for (const Fused act : {Fused::None, Fused::Tanh}) {
      const Tensor y = ag::gather_add(a, a_rows, b, b_rows, act);
      const std::vector<Tensor> fast = ag::grad({y}, {a, b}, {g}, true, false);
      const std::vector<Tensor> recorded = ag::grad({y}, {a, b}, {g}, true, true);
      for (std::size_t i = 0; i < fast.size(); ++i)
        expect_close(fast[i], recorded[i].detach(), 1e-11,
                     "gather_add gradient " + std::to_string(i) + " on " + std::to_string(threads) + " thread(s)");
    }
  }
}

TEST(GatherAdd, RejectsMismatchedTablesAndIndices) {
  const Tensor a = ag::zeros({3, 4}), b = ag::zeros({2, 4});
  expect_throw_with([&] { ag::gather_add(a, {0}, ag::zeros({2, 5}), {0}); }, {"same row length", "[3, 4]", "[2, 5]"});
  expect_throw_with([&] { ag::gather_add(a, {0, 1}, b, {0}); }, {"2 rows of the first table but 1 of the second"});
  expect_throw_with([&] { ag::gather_add(a, {3}, b, {0}); }, {"first table's index 3 at position 0", "[0, 3)"});
  expect_throw_with([&] { ag::gather_add(a, {0}, b, {-1}); }, {"second table's index -1"});
}

// parallel_mlp and mlp against the layer ops they stack.
TEST(ParallelMlp, EqualsStackedParallelLinearsAndDifferentiates) {
  for (const bool shared : {false, true}) {
    for (const bool bias : {false, true}) {
      for (const Fused act : {Fused::None, Fused::Tanh}) {
        const std::string what =
            std::string(shared ? "shared" : "batched") + (bias ? ", bias" : "") + (act == Fused::Tanh ? ", tanh" : "");
        const Tensor x = shared ? randn64({5, 3}, 70) : randn64({2, 5, 3}, 70);
        const std::vector<Tensor> w = {randn64({2, 3, 4}, 71), randn64({2, 4, 2}, 72)};
        const std::vector<Tensor> b =
            bias ? std::vector<Tensor>{randn64({2, 1, 4}, 73), randn64({2, 1, 2}, 74)} : std::vector<Tensor>{};
        const Tensor stacked = ag::parallel_linear(ag::parallel_linear(x, w[0], bias ? b[0] : Tensor(), act), w[1],
                                                   bias ? b[1] : Tensor(), act);
        expect_close(ag::parallel_mlp(x, w, b, act), stacked, 1e-13, what);
        Inputs inputs{x, w[0], w[1]};
        if (bias) inputs.insert(inputs.end(), b.begin(), b.end());
        expect_grad_and_gradgrad(
            "parallel_mlp " + what,
            [act, bias](const Inputs& in) {
              return ag::parallel_mlp(in[0], {in[1], in[2]},
                                      bias ? std::vector<Tensor>{in[3], in[4]} : std::vector<Tensor>{}, act);
            },
            inputs);
      }
    }
  }
}

TEST(ParallelMlp, FastGradientsEqualTheRecordedOnes) {
  for (const int threads : {1, 2}) {
    ThreadsGuard guard(threads);
    const Tensor x = randn64({1100, 6}, 80);  // shared input, as MAPS's modules see the observations
    const std::vector<Tensor> w = {randn64({3, 6, 8}, 81), randn64({3, 8, 8}, 82), randn64({3, 8, 5}, 83)};
    const std::vector<Tensor> b = {randn64({3, 1, 8}, 84), randn64({3, 1, 8}, 85), randn64({3, 1, 5}, 86)};
    const Tensor g = randn64({3, 1100, 5}, 87, false);
    const Tensor y = ag::parallel_mlp(x.detach(), w, b, Fused::Tanh);  // the input needs no gradient: fast path
    const std::vector<Tensor> params{w[0], w[1], w[2], b[0], b[1], b[2]};
    const std::vector<Tensor> fast = ag::grad({y}, params, {g}, true, false);
    const std::vector<Tensor> recorded = ag::grad({y}, params, {g}, true, true);
    for (std::size_t i = 0; i < fast.size(); ++i)
      expect_close(fast[i], recorded[i].detach(), 1e-12, "gradient " + std::to_string(i));
  }
}

TEST(Mlp, EqualsStackedLinearsAndDifferentiatesOverRowBlocksAndThreads) {
  for (const int threads : {1, 2}) {
    ThreadsGuard guard(threads);
    for (const bool bias : {false, true}) {
      // 1100 rows, 4.7M multiply-adds: three blocks of 512 on one thread, two ranges on two.
      const Tensor x = randn64({1100, 64}, 90);
      const std::vector<Tensor> w = {randn64({64, 64}, 91), randn64({3, 64}, 92)};
      const std::vector<Tensor> b =
          bias ? std::vector<Tensor>{randn64({64}, 93), randn64({3}, 94)} : std::vector<Tensor>{};
      for (const Fused last : {Fused::None, Fused::Tanh}) {
        const Tensor stacked =
            ag::linear(ag::linear(x, w[0], bias ? b[0] : Tensor(), Fused::Tanh), w[1], bias ? b[1] : Tensor(), last);
        const Tensor y = ag::mlp(x, w, b, Fused::Tanh, last);
        expect_close(y, stacked, 1e-13, "mlp");
        const Tensor g = randn64({1100, 3}, 95, false);
        Inputs inputs{x, w[0], w[1]};
        if (bias) inputs.insert(inputs.end(), b.begin(), b.end());
        const std::vector<Tensor> fast = ag::grad({y}, inputs, {g}, true, false);
        const std::vector<Tensor> recorded = ag::grad({y}, inputs, {g}, true, true);
        const std::vector<Tensor> reference = ag::grad({stacked}, inputs, {g});
        for (std::size_t i = 0; i < fast.size(); ++i) {
          expect_close(fast[i], recorded[i].detach(), 1e-11, "mlp gradient " + std::to_string(i));
          expect_close(fast[i], reference[i], 1e-11, "mlp gradient vs linears " + std::to_string(i));
        }
      }
    }
  }
  const Tensor x = randn64({4, 3}, 96), w0 = randn64({5, 3}, 97), w1 = randn64({2, 5}, 98), b0 = randn64({5}, 99),
               b1 = randn64({2}, 100);
  expect_grad_and_gradgrad("mlp",
                           [](const Inputs& in) {
                             return ag::mlp(in[0], {in[1], in[2]}, {in[3], in[4]}, Fused::Tanh);
                           },
                           {x, w0, w1, b0, b1});
}

TEST(Mlp, RejectsLayersThatDoNotChain) {
  expect_throw_with(
      [] {
        ag::mlp(ag::zeros({4, 3}), {ag::zeros({5, 3}), ag::zeros({2, 4})}, {}, Fused::Tanh);
      },
      {"weight 1", "[2, 4]", "does not fit [out, 5]"});
  expect_throw_with(
      [] {
        ag::mlp(ag::zeros({4, 3}), {ag::zeros({5, 3})}, {ag::zeros({4})}, Fused::Tanh);
      },
      {"bias 0", "[4]"});
  expect_throw_with([] { ag::mlp(ag::zeros({4, 3}), {}, {}, Fused::Tanh); }, {"at least one layer"});
  expect_throw_with(
      [] {
        ag::parallel_mlp(ag::zeros({4, 3}), {ag::zeros({2, 3, 5}), ag::zeros({2, 4, 1})}, {}, Fused::Tanh);
      },
      {"weight 1", "does not follow [2, ., 5]"});
  expect_throw_with(
      [] {
        ag::parallel_mlp(ag::zeros({4, 3}), {ag::zeros({2, 3, 5})}, {ag::zeros({2, 5})}, Fused::Tanh);
      },
      {"bias 0", "[2, 5]"});
}

TEST(LayerOps, NoRowsGiveZeroWeightGradientsAndNoCrash) {
  for (const Fused act : {Fused::None, Fused::Tanh}) {
    const Tensor w = randn64({5, 4}, 110), b = randn64({5}, 111);
    const std::vector<Tensor> lg = ag::grad({ag::sum(ag::linear(randn64({0, 4}, 112), w, b, act))}, {w, b});
    agtest::expect_values(lg[0], {5, 4}, std::vector<double>(20, 0.0));
    agtest::expect_values(lg[1], {5}, std::vector<double>(5, 0.0));
    const std::vector<Tensor> mw = {randn64({5, 4}, 113), randn64({2, 5}, 114)};
    const std::vector<Tensor> mg = ag::grad({ag::sum(ag::mlp(randn64({0, 4}, 115), mw, {}, act))}, mw);
    agtest::expect_values(mg[0], {5, 4}, std::vector<double>(20, 0.0));
    const Tensor pw = randn64({2, 4, 3}, 116), pb = randn64({2, 1, 3}, 117);
    for (int reuse = 0; reuse < 2; ++reuse) {  // the second time, the pool hands back the first one's blocks
      const std::vector<Tensor> pg =
          ag::grad({ag::sum(ag::parallel_linear(randn64({2, 0, 4}, 118), pw, pb, act))}, {pw, pb});
      agtest::expect_values(pg[0], {2, 4, 3}, std::vector<double>(24, 0.0));
      agtest::expect_values(pg[1], {2, 1, 3}, std::vector<double>(6, 0.0));
    }
    const std::vector<Tensor> sg =
        ag::grad({ag::sum(ag::parallel_mlp(randn64({2, 0, 4}, 119), {pw}, {pb}, act))}, {pw});
    agtest::expect_values(sg[0], {2, 4, 3}, std::vector<double>(24, 0.0));
  }
  agtest::expect_values(ag::gemm(randn64({3, 0}, 120, false), randn64({0, 4}, 121, false), false, false), {3, 4},
                        std::vector<double>(12, 0.0));
}

// The kernel's paths, each against plain loops in float64 and float32, on one thread and two: inner dimensions
// summed in blocks (k = 600 on a small output), narrow outputs done column-major (6 columns, tall), and products
// big enough to be split by rows and by columns.
TEST(GemmKernel, EveryPathMatchesPlainLoops) {
  struct Case {
    std::int64_t n, k, m;
    bool ta, tb;
  };
  const std::vector<Case> cases = {
      {20, 600, 24, true, false},  {24, 600, 20, false, true}, {200, 64, 6, false, false}, {6, 300, 100, true, true},
      {130, 90, 40, false, false}, {40, 90, 130, true, false}, {70, 70, 70, false, true},
  };
  for (const int threads : {1, 2}) {
    ThreadsGuard guard(threads);
    for (const Dtype dtype : agtest::kBothDtypes) {
      for (const Case& c : cases) {
        const Tensor a = randn64(c.ta ? Shape{c.k, c.n} : Shape{c.n, c.k}, 30, false).to(dtype);
        const Tensor b = randn64(c.tb ? Shape{c.m, c.k} : Shape{c.k, c.m}, 31, false).to(dtype);
        const Tensor out = ag::gemm(a, b, c.ta, c.tb);
        const std::vector<double> av = a.to_vector(), bv = b.to_vector();
        std::vector<double> expected(static_cast<std::size_t>(c.n * c.m));
        for (std::int64_t i = 0; i < c.n; ++i)
          for (std::int64_t j = 0; j < c.m; ++j) {
            double s = 0;
            for (std::int64_t q = 0; q < c.k; ++q)
              s += av[static_cast<std::size_t>(c.ta ? q * c.n + i : i * c.k + q)] *
                   bv[static_cast<std::size_t>(c.tb ? j * c.k + q : q * c.m + j)];
            expected[static_cast<std::size_t>(i * c.m + j)] = s;
          }
        const double tol = dtype == kF64 ? 1e-12 : 2e-4 * std::sqrt(static_cast<double>(c.k));
        expect_close(out, ag::from_vector(expected, {c.n, c.m}, kF64), tol,
                     "gemm " + std::to_string(c.n) + "x" + std::to_string(c.k) + "x" + std::to_string(c.m) + " on " +
                         std::to_string(threads) + " thread(s)");
      }
    }
  }
}

TEST(GemmKernel, TwoThreadsGiveTheSameTrainingGradients) {
  // 200 x 40 x 64 multiply-adds: above the size the kernel splits across threads.
  const Tensor x = randn64({200, 40}, 40), w = randn64({64, 40}, 41), b = randn64({64}, 42);
  auto gradients = [&] {
    const Tensor y = ag::linear(x, w, b, Fused::Tanh);
    return ag::grad({ag::sum(ag::square(y))}, {x, w, b});
  };
  const std::vector<Tensor> one = gradients();
  ThreadsGuard guard(2);
  const std::vector<Tensor> two = gradients();
  for (std::size_t i = 0; i < one.size(); ++i) expect_close(two[i], one[i], 1e-12, "gradient " + std::to_string(i));
}

TEST(ParallelFor, CoversEveryIndexOnceOnAnyThreadCount) {
  for (const int threads : {1, 2, 3}) {
    ThreadsGuard guard(threads);
    for (const std::int64_t count : {0, 1, 5, 1000}) {
      std::vector<std::atomic<int>> seen(static_cast<std::size_t>(count));
      ag::parallel_for(count, 2, [&](std::int64_t begin, std::int64_t end) {
        ASSERT_LE(0, begin);
        ASSERT_LE(begin, end);
        ASSERT_LE(end, count);
        for (std::int64_t i = begin; i < end; ++i) ++seen[static_cast<std::size_t>(i)];
      });
      for (std::int64_t i = 0; i < count; ++i) EXPECT_EQ(seen[static_cast<std::size_t>(i)].load(), 1) << i;
    }
  }
}

TEST(ParallelFor, RethrowsARangesExceptionAndRunsNestedCallsInPlace) {
  ThreadsGuard guard(2);
  expect_throw_with(
      [] {
        ag::parallel_for(100, 1, [](std::int64_t begin, std::int64_t) {
          if (begin > 0) throw std::runtime_error("range failed");
        });
      },
      {"range failed"});
  std::atomic<int> inner_ranges{0};
  ag::parallel_for(100, 1, [&](std::int64_t, std::int64_t) {
    ag::parallel_for(100, 1, [&](std::int64_t begin, std::int64_t end) {
      EXPECT_EQ(begin, 0);
      EXPECT_EQ(end, 100);
      ++inner_ranges;
    });
  });
  EXPECT_EQ(inner_ranges.load(), 2);  // one whole inner range per outer range
}

TEST(ParallelFor, RangesAreFixedByCountAndRangesOnAnyThreadCount) {
  for (const int threads : {1, 2}) {
    ThreadsGuard guard(threads);
    std::vector<std::array<std::int64_t, 2>> seen(3, {-1, -1});
    ag::parallel_for_ranges(10, 3, [&](std::int64_t r, std::int64_t begin, std::int64_t end) {
      seen[static_cast<std::size_t>(r)] = {begin, end};
    });
    EXPECT_EQ(seen, (std::vector<std::array<std::int64_t, 2>>{{0, 3}, {3, 6}, {6, 10}}));
    std::atomic<int> calls{0};
    ag::parallel_for_ranges(2, 5, [&](std::int64_t r, std::int64_t begin, std::int64_t end) {
      EXPECT_EQ(end - begin, 1) << r;  // more ranges than items: one item each
      ++calls;
    });
    EXPECT_EQ(calls.load(), 2);
    EXPECT_EQ(ag::parallel_ranges(0, 4), 0);
    EXPECT_EQ(ag::parallel_ranges(100, 10), threads);
    EXPECT_EQ(ag::parallel_ranges(100, 60), 1);
  }
  ThreadsGuard guard(2);
  ag::parallel_for(100, 1, [](std::int64_t, std::int64_t) { EXPECT_EQ(ag::parallel_ranges(100, 1), 1); });
}

TEST(ParallelFor, RejectsAThreadCountBelowOneOrAboveTheBound) {
  expect_throw_with([] { ag::set_num_threads(0); }, {"threads must be in [1, 256], got 0"});
  expect_throw_with([] { ag::set_num_threads(ag::kMaxThreads + 1); }, {"threads must be in [1, 256], got 257"});
  EXPECT_EQ(ag::num_threads(), 1);
}

TEST(StoragePool, ReusesAFreedBlockOfTheSameSize) {
  if (!ag::detail::pool_enabled()) GTEST_SKIP() << "AddressSanitizer build: the pool hands every block back";
  const void* first = nullptr;
  {
    const Tensor t = ag::empty({123, 77});
    first = t.data<float>();
  }
  EXPECT_GE(ag::detail::pool_cached_bytes(), 123u * 77u * 4u);
  const Tensor again = ag::zeros({123, 77});
  EXPECT_EQ(static_cast<const void*>(again.data<float>()), first);
  EXPECT_EQ(again.to_vector(), std::vector<double>(123 * 77, 0.0));  // reused memory is still initialised
}

}  // namespace
