// The engine: backward() and grad(), graph lifetime, grad mode, higher-order gradients, deep graphs.

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Dtype;
using ag::Shape;
using ag::Tensor;
using agtest::expect_throw_with;
using agtest::expect_values;
using agtest::kF32;
using agtest::kF64;
using agtest::randn64;
using agtest::tensor;

using Inputs = std::vector<Tensor>;

// ----- backward() -----

TEST(Backward, ScalarOutputFillsLeafGrads) {
  const Tensor x = tensor({1, 2, 3}, {3}, kF64, true);
  const Tensor w = tensor({4, 5, 6}, {3}, kF64, true);
  ag::sum(x * w).backward();
  expect_values(x.grad(), {3}, {4, 5, 6});
  expect_values(w.grad(), {3}, {1, 2, 3});
  EXPECT_FALSE(x.grad().requires_grad());  // no create_graph: a plain tensor
  EXPECT_EQ(x.grad().grad_fn(), nullptr);
}

TEST(Backward, AccumulatesIntoLeavesOverTwoCalls) {
  const Tensor x = tensor({1, -2, 3}, {3}, kF64, true);
  ag::sum(x * x).backward();
  expect_values(x.grad(), {3}, {2, -4, 6});
  ag::sum(x * 3.0).backward();
  expect_values(x.grad(), {3}, {5, -1, 9});
  // The free function, too.
  ag::backward({ag::sum(x)});
  expect_values(x.grad(), {3}, {6, 0, 10});
}

TEST(Backward, LeavesWithoutRequiresGradGetNothing) {
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor c = tensor({3, 4}, {2}, kF64, false);
  ag::sum(x * c).backward();
  EXPECT_TRUE(x.grad().defined());
  EXPECT_FALSE(c.grad().defined());
}

TEST(Backward, NonLeafGetsNoGrad) {
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor h = x * 2.0;
  ag::sum(h * h).backward();
  expect_values(x.grad(), {2}, {8, 16});
  EXPECT_FALSE(h.grad().defined());
}

TEST(Backward, GradOutputsGiveVectorJacobianProducts) {
  const Tensor x = tensor({1, 2, 3}, {3}, kF64, true);
  const Tensor y = x * x;
  y.backward(tensor({1, 0.5, -1}, {3}));
  expect_values(x.grad(), {3}, {2, 2, -6});
  const Tensor z = tensor({1, 2, 3, 4}, {2, 2}, kF64, true);
  ag::backward({ag::exp(z)}, {ag::ones({2, 2}, kF64)});
  expect_values(z.grad(), {2, 2}, {std::exp(1.0), std::exp(2.0), std::exp(3.0), std::exp(4.0)});
}

TEST(Backward, SeveralOutputsSum) {
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  ag::backward({ag::sum(x * x), ag::sum(x * 10.0)});
  expect_values(x.grad(), {2}, {12, 14});
}

TEST(Backward, OneElementOutputOfAnyRankNeedsNoGradOutput) {
  const Tensor x = tensor({3}, {1, 1}, kF64, true);
  (x * x).backward();
  expect_values(x.grad(), {1, 1}, {6});
}

TEST(Backward, NonScalarOutputWithoutGradOutputsThrows) {
  const Tensor x = tensor({1, 2, 3}, {3}, kF64, true);
  const Tensor y = x * 2.0;
  EXPECT_THROW(y.backward(), std::exception);
  EXPECT_THROW(ag::backward({y}), std::exception);
  EXPECT_THROW(ag::grad({y}, {x}), std::exception);
  EXPECT_FALSE(x.grad().defined());
}

TEST(Backward, GradOutputOfWrongShapeThrows) {
  const Tensor x = tensor({1, 2, 3}, {3}, kF64, true);
  const Tensor y = x * 2.0;
  EXPECT_THROW(y.backward(ag::ones({2}, kF64)), std::exception);
  EXPECT_THROW(ag::grad({y}, {x}, {ag::ones({3, 1}, kF64)}), std::exception);
}

TEST(Backward, Float32GraphGivesFloat32Grads) {
  Tensor x = ag::from_vector(std::vector<float>{0.5f, -1.0f}, {2});
  x.requires_grad_();
  ag::sum(ag::tanh(x) * x).backward();
  ASSERT_TRUE(x.grad().defined());
  EXPECT_EQ(x.grad().dtype(), kF32);
  std::vector<double> expected;
  for (double v : {0.5, -1.0}) expected.push_back(std::tanh(v) + v * (1 - std::tanh(v) * std::tanh(v)));
  expect_values(x.grad(), {2}, expected, 1e-5);
}

// ----- freed graphs and retain_graph -----

TEST(Backward, SecondPassThroughFreedGraphIsAClearError) {
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor y = ag::sum(ag::exp(x) * x);
  y.backward();
  ASSERT_NE(y.grad_fn(), nullptr);
  EXPECT_TRUE(y.grad_fn()->released());
  expect_throw_with([&] { y.backward(); }, {"retain_graph"});
  expect_throw_with([&] { ag::grad({y}, {x}); }, {"retain_graph"});
}

TEST(Backward, RetainGraphAllowsASecondPass) {
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor y = ag::sum(ag::exp(x) * x);
  y.backward(Tensor(), /*retain_graph=*/true);
  EXPECT_FALSE(y.grad_fn()->released());
  y.backward();
  std::vector<double> expected;
  for (double v : {1.0, 2.0}) expected.push_back(2 * (std::exp(v) * (1 + v)));
  expect_values(x.grad(), {2}, expected);
  EXPECT_THROW(y.backward(), std::exception);
}

TEST(Backward, GradWithRetainGraphThenBackward) {
  const Tensor x = tensor({0.5, 1.5}, {2}, kF64, true);
  const Tensor y = ag::sum(ag::tanh(x) * x);
  const Tensor g = ag::grad({y}, {x}, {}, /*retain_graph=*/true)[0];
  y.backward();
  agtest::expect_close(x.grad(), g);
}

TEST(Backward, RetainGraphDefaultsToCreateGraph) {
  const Tensor x = tensor({0.5, 1.5}, {2}, kF64, true);
  const Tensor y = ag::sum(ag::pow(x, 3.0));
  const Tensor g = ag::grad({y}, {x}, {}, std::nullopt, /*create_graph=*/true)[0];
  EXPECT_FALSE(y.grad_fn()->released());
  y.backward();  // the graph was kept
  expect_values(x.grad(), {2}, {0.75, 6.75});
}

// ----- grad() -----

TEST(Grad, ReturnsGradientsWithoutTouchingGrad) {
  Tensor x = tensor({1, 2, 3}, {3}, kF64, true);
  const Tensor w = tensor({2, 2, 2}, {3}, kF64, true);
  const std::vector<Tensor> g = ag::grad({ag::sum(x * x * w)}, {x, w});
  ASSERT_EQ(g.size(), 2u);
  expect_values(g[0], {3}, {4, 8, 12});
  expect_values(g[1], {3}, {1, 4, 9});
  EXPECT_FALSE(x.grad().defined());
  EXPECT_FALSE(w.grad().defined());
  EXPECT_FALSE(g[0].requires_grad());
  // An existing grad is left alone too.
  x.set_grad(tensor({7, 7, 7}, {3}));
  ag::grad({ag::sum(x * x)}, {x});
  expect_values(x.grad(), {3}, {7, 7, 7});
}

TEST(Grad, WithRespectToAnIntermediateTensor) {
  const Tensor x = tensor({1, -2}, {2}, kF64, true);
  const Tensor h = x * 3.0;
  const Tensor y = ag::sum(h * h);
  const std::vector<Tensor> g = ag::grad({y}, {h, x});
  expect_values(g[0], {2}, {6, -12});   // 2 h
  expect_values(g[1], {2}, {18, -36});  // 18 x
}

TEST(Grad, WithGradOutputsAndSeveralOutputs) {
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor a = x * x;
  const Tensor b = x * 5.0;
  const Tensor g = ag::grad({a, b}, {x}, {tensor({1, 10}, {2}), tensor({1, 1}, {2})})[0];
  expect_values(g, {2}, {2 + 5, 40 + 5});
}

TEST(Grad, AllowUnused) {
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor unused = tensor({3, 4}, {2}, kF64, true);
  const Tensor y = ag::sum(x * 2.0);
  EXPECT_THROW(ag::grad({y}, {x, unused}, {}, true), std::exception);
  const std::vector<Tensor> g = ag::grad({y}, {x, unused}, {}, std::nullopt, false, /*allow_unused=*/true);
  ASSERT_EQ(g.size(), 2u);
  expect_values(g[0], {2}, {2, 2});
  EXPECT_FALSE(g[1].defined());
}

TEST(Grad, DiamondGraphSumsBothPaths) {
  const Tensor x = tensor({0.5, -1}, {2}, kF64, true);
  const Tensor a = x * 2.0;
  const Tensor b = ag::exp(x);
  const Tensor g = ag::grad({ag::sum(a * b)}, {x})[0];
  std::vector<double> expected;
  for (double v : {0.5, -1.0}) expected.push_back(2 * std::exp(v) + 2 * v * std::exp(v));
  expect_values(g, {2}, expected);
  // The same tensor twice in one op.
  expect_values(ag::grad({ag::sum(x + x)}, {x})[0], {2}, {2, 2});
  expect_values(ag::grad({ag::sum(x * x)}, {x})[0], {2}, {1, -2});
}

// ----- higher order -----

TEST(Grad, CreateGraphSecondDerivativeOfCube) {
  const std::vector<double> xs = {0.5, -1.5, 2};
  for (int form = 0; form < 2; ++form) {
    SCOPED_TRACE(form == 0 ? "pow(x, 3)" : "x * x * x");
    const Tensor x = tensor(xs, {3}, kF64, true);
    const Tensor y = ag::sum(form == 0 ? ag::pow(x, 3.0) : x * x * x);
    const Tensor g = ag::grad({y}, {x}, {}, std::nullopt, /*create_graph=*/true)[0];
    EXPECT_TRUE(g.requires_grad());
    expect_values(g, {3}, {3 * 0.25, 3 * 2.25, 3 * 4.0});
    const Tensor g2 = ag::grad({ag::sum(g)}, {x}, {}, std::nullopt, true)[0];
    expect_values(g2, {3}, {6 * 0.5, 6 * -1.5, 6 * 2.0});
    const Tensor g3 = ag::grad({ag::sum(g2)}, {x})[0];
    expect_values(g3, {3}, {6, 6, 6});
  }
}

TEST(Grad, HessianVectorProductThroughBackward) {
  // f = sum(x^2 * y); grad_x = 2 x y; d/dx sum(grad_x * v) = 2 y v, d/dy = 2 x v.
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor y = tensor({3, -1}, {2}, kF64, true);
  const Tensor gx = ag::grad({ag::sum(x * x * y)}, {x}, {}, std::nullopt, true)[0];
  ag::sum(gx * tensor({1, 10}, {2})).backward();
  expect_values(x.grad(), {2}, {6, -20});
  expect_values(y.grad(), {2}, {2, 40});
}

TEST(Grad, CreateGraphWithBackwardIntoLeaves) {
  Tensor x = tensor({2}, {}, kF64, true);
  ag::backward({ag::pow(x, 4.0)}, {}, std::nullopt, /*create_graph=*/true);
  ASSERT_TRUE(x.grad().defined());
  expect_values(x.grad(), {}, {32});
  EXPECT_TRUE(x.grad().requires_grad());
  const Tensor second = ag::grad({x.grad()}, {x})[0];
  expect_values(second, {}, {48});
  x.set_grad(Tensor());  // break the cycle leaf -> grad -> graph -> leaf
}

// ----- custom ops through record() -----

Tensor scaled_exp(const Tensor& x) {
  Tensor result;
  {
    ag::NoGradGuard no_grad;
    result = ag::exp(x);
  }
  // The rule reads the saved output: d exp(x) = exp(x) dx.
  return ag::record(
      "scaled_exp", result, {x},
      [](const Tensor& g, const std::vector<bool>&, ag::Node& self) { return std::vector<Tensor>{g * self.output()}; },
      /*save_output=*/true);
}

TEST(Record, CustomOpWithSavedOutputIsDifferentiableTwice) {
  const Tensor y = scaled_exp(randn64({3}, 1));
  ASSERT_NE(y.grad_fn(), nullptr);
  EXPECT_EQ(y.grad_fn()->op(), "scaled_exp");
  EXPECT_EQ(y.grad_fn()->inputs().size(), 1u);
  agtest::expect_grad_and_gradgrad("scaled_exp", [](const Inputs& in) { return scaled_exp(in[0]); },
                                   {randn64({2, 3}, 2)});
}

TEST(Record, RecordsNothingWithoutGradOrUnderNoGrad) {
  const Tensor plain = randn64({3}, 1, false);
  EXPECT_FALSE(ag::any_requires_grad({plain}));
  EXPECT_EQ(scaled_exp(plain).grad_fn(), nullptr);
  EXPECT_FALSE(scaled_exp(plain).requires_grad());
  const Tensor x = randn64({3}, 2);
  EXPECT_TRUE(ag::any_requires_grad({plain, x}));
  EXPECT_FALSE(ag::any_requires_grad({Tensor(), plain}));
  ag::NoGradGuard no_grad;
  EXPECT_FALSE(ag::any_requires_grad({x}));
  EXPECT_EQ(scaled_exp(x).grad_fn(), nullptr);
}

// ----- grad mode -----

TEST(GradMode, NoGradGuardResultsDoNotRequireGrad) {
  const Tensor x = randn64({2, 3}, 1);
  {
    ag::NoGradGuard no_grad;
    for (const Tensor& y : {x * 2.0, ag::tanh(x), ag::matmul(x, ag::transpose(x, 0, 1)), ag::sum(x), ag::softmax(x, 1),
                            ag::concat({x, x}, 0), x.clone(), x.to(kF32)}) {
      EXPECT_FALSE(y.requires_grad());
      EXPECT_EQ(y.grad_fn(), nullptr);
    }
  }
  // Restored on scope exit.
  EXPECT_TRUE(ag::GradMode::is_enabled());
  const Tensor y = x * 2.0;
  EXPECT_TRUE(y.requires_grad());
  EXPECT_NE(y.grad_fn(), nullptr);
}

TEST(GradMode, NoGradGuardIsThreadLocal) {
  const Tensor x = randn64({3}, 1);
  bool other_enabled = false;
  bool other_records = false;
  {
    ag::NoGradGuard no_grad;
    EXPECT_FALSE((x * 2.0).requires_grad());
    std::thread other([&] {
      other_enabled = ag::GradMode::is_enabled();
      const Tensor y = x * 2.0;
      other_records = y.requires_grad() && y.grad_fn() != nullptr;
    });
    other.join();
    EXPECT_FALSE(ag::GradMode::is_enabled());
  }
  EXPECT_TRUE(other_enabled);
  EXPECT_TRUE(other_records);
  // And a guard on another thread leaves this one alone.
  std::thread guarded([&] {
    ag::NoGradGuard no_grad;
    other_records = (x * 2.0).requires_grad();
  });
  guarded.join();
  EXPECT_FALSE(other_records);
  EXPECT_TRUE(ag::GradMode::is_enabled());
  EXPECT_TRUE((x * 2.0).requires_grad());
}

TEST(GradMode, BackwardOfAGraphBuiltEarlierWorksUnderNoGrad) {
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor y = ag::sum(x * x);
  ag::NoGradGuard no_grad;
  y.backward();
  expect_values(x.grad(), {2}, {2, 4});
}

TEST(Engine, IndependentGraphsOnTwoThreads) {
  std::atomic<int> failures{0};
  auto work = [&failures](std::uint64_t seed) {
    for (int i = 0; i < 200; ++i) {
      const Tensor x = randn64({4, 3}, seed + static_cast<std::uint64_t>(i));
      const Tensor w = randn64({3, 2}, seed + 1000 + static_cast<std::uint64_t>(i));
      ag::sum(ag::tanh(ag::matmul(x, w))).backward();
      // d/dw = x^T (1 - tanh^2)
      Tensor expected;
      {
        ag::NoGradGuard no_grad;
        const Tensor t = ag::tanh(ag::matmul(x, w));
        expected = ag::matmul(ag::transpose(x, 0, 1), ag::rsub(1.0, t * t));
      }
      const std::vector<double> got = w.grad().to_vector(), want = expected.to_vector();
      for (std::size_t k = 0; k < got.size(); ++k) {
        if (std::abs(got[k] - want[k]) > 1e-12) ++failures;
      }
    }
  };
  std::thread a(work, 1);
  std::thread b(work, 50000);
  a.join();
  b.join();
  EXPECT_EQ(failures.load(), 0);
}

// ----- deep graphs -----

TEST(Engine, DeepChainBackwardDoesNotOverflowTheStack) {
  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  Tensor y = x;
  for (int i = 0; i < 10000; ++i) y = y * 1.0001;
  ag::sum(y).backward();
  const double expected = std::pow(1.0001, 10000);
  expect_values(x.grad(), {2}, {expected, expected}, 1e-10);
}

TEST(Engine, VeryDeepChainBackwardAndTeardown) {
  // Deep enough that a recursive walk or a recursive destructor would overflow an 8 MiB stack.
  const Tensor x = tensor({1}, {}, kF64, true);
  Tensor y = x;
  for (int i = 0; i < 100000; ++i) y = y + 1e-6;
  EXPECT_NEAR(y.item(), 1.1, 1e-9);
  const Tensor g = ag::grad({y}, {x})[0];
  expect_values(g, {}, {1});
  // A deep graph dropped without any backward pass.
  Tensor z = x;
  for (int i = 0; i < 100000; ++i) z = ag::tanh(z);
  z = Tensor();
  y = Tensor();
  SUCCEED();
}

TEST(Engine, DeepChainCreateGraph) {
  const Tensor x = tensor({0.3}, {}, kF64, true);
  Tensor y = x;
  for (int i = 0; i < 2000; ++i) y = y * 1.0001 + 1e-4;
  const double chain = std::pow(1.0001, 2000);  // dy/dx
  // y^2, so that the gradient 2 y dy/dx depends on x and carries a graph.
  const Tensor g = ag::grad({ag::square(y)}, {x}, {}, std::nullopt, /*create_graph=*/true)[0];
  EXPECT_NEAR(g.item(), 2 * y.item() * chain, 1e-9);
  EXPECT_TRUE(g.requires_grad());
  const Tensor g2 = ag::grad({g}, {x})[0];
  EXPECT_NEAR(g2.item(), 2 * chain * chain, 1e-9);
}

// ----- graph memory -----

struct Watch {
  std::weak_ptr<ag::TensorImpl> impl;
  std::weak_ptr<ag::Node> node;
  std::weak_ptr<ag::Storage> storage;
  void watch(const Tensor& t) {
    impl = t.impl();
    node = t.grad_fn();
    storage = t.impl()->storage;
  }
  void expect_freed(const std::string& what) const {
    EXPECT_TRUE(impl.expired()) << what << ": the intermediate tensor is still alive";
    EXPECT_TRUE(node.expired()) << what << ": its node is still alive";
    EXPECT_TRUE(storage.expired()) << what << ": its storage is still alive";
  }
};

struct MemoryCase {
  std::string name;
  std::function<Tensor(const Tensor&)> op;
};

std::vector<MemoryCase> memory_cases() {
  return {
      {"tanh", [](const Tensor& x) { return ag::tanh(x); }},
      {"exp", [](const Tensor& x) { return ag::exp(x); }},
      {"sigmoid", [](const Tensor& x) { return ag::sigmoid(x); }},
      {"softmax", [](const Tensor& x) { return ag::softmax(x, 1); }},
      {"log_softmax", [](const Tensor& x) { return ag::log_softmax(x, 1); }},
      {"sqrt", [](const Tensor& x) { return ag::sqrt(ag::abs(x) + 1.0); }},
      {"mul", [](const Tensor& x) { return x * x; }},
      {"matmul", [](const Tensor& x) { return ag::matmul(x, ag::transpose(x, 0, 1)); }},
      {"scaled_exp", [](const Tensor& x) { return scaled_exp(x); }},
  };
}

TEST(GraphMemory, FreedWhenOutputsGoOutOfScope) {
  for (const MemoryCase& c : memory_cases()) {
    const Tensor x = randn64({2, 3}, 1);
    Watch mid, out;
    {
      const Tensor m = c.op(x);
      const Tensor y = ag::sum(m * 2.0);
      mid.watch(m);
      out.watch(y);
    }
    mid.expect_freed(c.name + " without backward");
    out.expect_freed(c.name + " output without backward");
  }
}

TEST(GraphMemory, FreedAfterBackward) {
  for (const MemoryCase& c : memory_cases()) {
    for (bool retain : {false, true}) {
      const Tensor x = randn64({2, 3}, 1);
      Watch mid;
      {
        const Tensor m = c.op(x);
        const Tensor y = ag::sum(ag::tanh(m));
        mid.watch(m);
        y.backward(Tensor(), retain);
      }
      EXPECT_TRUE(x.grad().defined());
      mid.expect_freed(c.name + (retain ? " after backward with retain_graph" : " after backward"));
    }
  }
}

TEST(GraphMemory, FreedAfterCreateGraph) {
  for (const MemoryCase& c : memory_cases()) {
    const Tensor x = randn64({2, 3}, 1);
    Watch mid, grad, second;
    {
      const Tensor m = c.op(x);
      const Tensor y = ag::sum(ag::square(m));
      mid.watch(m);
      const Tensor g = ag::grad({y}, {x}, {}, std::nullopt, /*create_graph=*/true)[0];
      grad.watch(g);
      const Tensor gg = ag::grad({ag::sum(ag::square(g))}, {x}, {}, std::nullopt, /*create_graph=*/true)[0];
      second.watch(gg);
    }
    mid.expect_freed(c.name + " after create_graph");
    grad.expect_freed(c.name + " gradient graph");
    second.expect_freed(c.name + " second gradient graph");
  }
}

TEST(GraphMemory, LeafOutlivesGraphAndKeepsOnlyItsGrad) {
  const Tensor x = randn64({3}, 1);
  std::weak_ptr<ag::Node> node;
  {
    const Tensor y = ag::sum(ag::exp(x));
    node = y.grad_fn();
    y.backward();
  }
  EXPECT_TRUE(node.expired());
  EXPECT_EQ(x.impl().use_count(), 1);
  ASSERT_TRUE(x.grad().defined());
  EXPECT_EQ(x.grad().grad_fn(), nullptr);
}

}  // namespace
