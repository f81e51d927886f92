// gradcheck and gradgradcheck themselves: they catch wrong rules, report what disagrees, honour
// their options, and check composites such as MAML's meta-gradient.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Shape;
using ag::Tensor;
using agtest::expect_grad_and_gradgrad;
using agtest::expect_gradcheck;
using agtest::kF32;
using agtest::kF64;
using agtest::randn64;
using agtest::tensor;
using ::testing::HasSubstr;

using Inputs = std::vector<Tensor>;

// x^2 with a hand-written rule; `factor` 2 is right, anything else is a deliberately wrong rule.
Tensor square_with_rule(const char* op, const Tensor& x, double factor, bool detach_in_rule = false) {
  Tensor result;
  {
    ag::NoGradGuard no_grad;
    result = ag::mul(x, x);
  }
  return ag::record(op, result, {x},
                    [factor, detach_in_rule](const Tensor& g, const std::vector<bool>&, ag::Node& self) {
                      const Tensor& input = self.inputs()[0];
                      return std::vector<Tensor>{g * (detach_in_rule ? input.detach() : input) * factor};
                    });
}

Tensor good_square(const Tensor& x) { return square_with_rule("good_square", x, 2.0); }
Tensor bad_square(const Tensor& x) { return square_with_rule("bad_square", x, 1.0); }                  // g*x, not 2*g*x
Tensor detached_square(const Tensor& x) { return square_with_rule("detached_square", x, 2.0, true); }  // no 2nd order

// Every number written in `text` (a hand-rolled scan: std::regex trips GCC 12 warnings under sanitizers).
std::vector<double> numbers_in(const std::string& text) {
  std::vector<double> out;
  const char* p = text.c_str();
  auto digit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
  while (*p != '\0') {
    if (digit(*p) || ((*p == '-' || *p == '+' || *p == '.') && digit(p[1]))) {
      char* end = nullptr;
      const double value = std::strtod(p, &end);
      if (end != p) {
        out.push_back(value);
        p = end;
        continue;
      }
    }
    ++p;
  }
  return out;
}

bool mentions(const std::vector<double>& numbers, double value, double tol) {
  for (double v : numbers) {
    if (std::abs(v - value) <= tol) return true;
  }
  return false;
}

TEST(Gradcheck, PassesACorrectHandWrittenRule) {
  expect_grad_and_gradgrad("good_square", [](const Inputs& in) { return good_square(in[0]); }, {randn64({2, 3}, 1)});
}

TEST(Gradcheck, CatchesAWrongBackwardRule) {
  const ag::GradcheckResult result =
      ag::gradcheck("bad_square", [](const Inputs& in) { return bad_square(in[0]); }, {randn64({2, 3}, 1)});
  EXPECT_FALSE(result.ok);
  EXPECT_THAT(result.message, HasSubstr("bad_square"));
}

TEST(Gradcheck, ReportsTheOpInputElementAndBothValues) {
  // Inputs 0 and 1 are fine; in input 2 only element 3 disagrees (the wrong rule is right where
  // x = 0): analytic g*x = 1.75, numerical 2x = 3.5.
  const Tensor a = randn64({5}, 1);
  const Tensor c = randn64({5}, 2);
  const Tensor b = tensor({0, 0, 0, 1.75, 0}, {5}, kF64, true);
  auto f = [](const Inputs& in) { return ag::mul(in[0], 2.0) + good_square(in[1]) + bad_square(in[2]); };
  const ag::GradcheckResult result = ag::gradcheck("bad_square", f, {a, c, b});
  ASSERT_FALSE(result.ok);
  SCOPED_TRACE(result.message);
  EXPECT_THAT(result.message, HasSubstr("bad_square"));
  EXPECT_THAT(result.message, HasSubstr("input"));
  const std::vector<double> numbers = numbers_in(result.message);
  EXPECT_TRUE(mentions(numbers, 2, 0)) << "the input index 2 is not named";
  EXPECT_TRUE(mentions(numbers, 3, 0)) << "the element 3 is not named";
  EXPECT_TRUE(mentions(numbers, 1.75, 1e-4)) << "the analytic value 1.75 is not named";
  EXPECT_TRUE(mentions(numbers, 3.5, 1e-4)) << "the numerical value 3.5 is not named";
}

TEST(Gradcheck, CatchesAWrongRuleInsideAComposite) {
  auto f = [](const Inputs& in) { return ag::sum(ag::tanh(bad_square(ag::matmul(in[0], in[1])))); };
  const ag::GradcheckResult result = ag::gradcheck("composite", f, {randn64({2, 3}, 1), randn64({3, 2}, 2)});
  EXPECT_FALSE(result.ok);
  EXPECT_FALSE(result.message.empty());
}

TEST(Gradcheck, GradgradcheckCatchesARuleThatIsNotDifferentiable) {
  // First derivatives are right, so gradcheck passes; the rule detaches x, so its own gradient is lost.
  auto f = [](const Inputs& in) { return detached_square(in[0]); };
  expect_gradcheck("detached_square", f, {randn64({2, 3}, 1)});
  const ag::GradcheckResult result = ag::gradgradcheck("detached_square", f, {randn64({2, 3}, 1)});
  EXPECT_FALSE(result.ok);
  EXPECT_THAT(result.message, HasSubstr("detached_square"));
}

TEST(Gradcheck, ToleranceOptionsAreHonoured) {
  auto f = [](const Inputs& in) { return bad_square(in[0]); };
  const Tensor x = tensor({0.001, -0.002}, {2}, kF64, true);  // error |x| <= 0.002
  EXPECT_FALSE(ag::gradcheck("bad_square", f, {x}).ok);
  ag::GradcheckOptions loose;
  loose.atol = 0.01;
  EXPECT_TRUE(ag::gradcheck("bad_square", f, {x}, loose).ok);
}

TEST(Gradcheck, LeavesInputValuesUnchanged) {
  const Tensor x = randn64({2, 3}, 1);
  const std::vector<double> before = x.to_vector();
  ag::gradcheck("tanh", [](const Inputs& in) { return ag::tanh(in[0]); }, {x});
  ag::gradgradcheck("tanh", [](const Inputs& in) { return ag::tanh(in[0]); }, {x});
  EXPECT_EQ(x.to_vector(), before);
}

TEST(Gradcheck, SkipsInputsThatDoNotRequireGrad) {
  // Input 1 does not require grad, so the wrong rule applied to it is never recorded nor checked.
  auto f = [](const Inputs& in) { return ag::mul(good_square(in[0]), 3.0) + bad_square(in[1]); };
  expect_gradcheck("good_square", f, {randn64({3}, 1), randn64({3}, 2, false)});
  EXPECT_FALSE(ag::gradcheck("bad_square", f, {randn64({3}, 1), randn64({3}, 2)}).ok);
}

TEST(Gradcheck, Float32InputsAreRefusedOrReported) {
  Tensor x = ag::from_vector(std::vector<float>{1, 2}, {2});
  x.requires_grad_();
  try {
    const ag::GradcheckResult result = ag::gradcheck("exp", [](const Inputs& in) { return ag::exp(in[0]); }, {x});
    EXPECT_FALSE(result.ok) << "gradcheck accepted float32 inputs";
    EXPECT_THAT(result.message, HasSubstr("float64"));
  } catch (const std::exception& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("float64"));
  }
}

TEST(Gradcheck, MultiOutputFunction) {
  auto f = [](const Inputs& in) -> std::vector<Tensor> { return {in[0] * in[1], ag::exp(in[0]), ag::sum(in[1])}; };
  agtest::expect_gradcheck("multi", f, {randn64({2, 3}, 1), randn64({3}, 2)});
  agtest::expect_gradgradcheck("multi", f, {randn64({2, 3}, 3), randn64({3}, 4)});
  // A wrong rule on the second output is still caught.
  auto bad = [](const Inputs& in) -> std::vector<Tensor> { return {in[0] * 2.0, bad_square(in[0])}; };
  EXPECT_FALSE(ag::gradcheck("multi", bad, {randn64({3}, 5)}).ok);
}

// The gradient of a loss taken after one inner SGD step, with respect to the initial parameters
// (MAML's meta-gradient), needs the inner gradient's own graph (create_graph).
Tensor meta_loss(const Tensor& w, const Tensor& b, const Tensor& x_in, const Tensor& y_in, const Tensor& x_out,
                 const Tensor& y_out) {
  const Tensor inner = ag::mse_loss(ag::tanh(ag::matmul(x_in, w) + b), y_in);
  const std::vector<Tensor> g = ag::grad({inner}, {w, b}, {}, std::nullopt, /*create_graph=*/true);
  const Tensor w1 = w - g[0] * 0.5;
  const Tensor b1 = b - g[1] * 0.5;
  return ag::mse_loss(ag::tanh(ag::matmul(x_out, w1) + b1), y_out);
}

TEST(Gradcheck, MamlMetaGradientMatchesFiniteDifferences) {
  const Tensor x_in = randn64({4, 2}, 10, false), y_in = randn64({4, 1}, 11, false);
  const Tensor x_out = randn64({3, 2}, 12, false), y_out = randn64({3, 1}, 13, false);
  auto f = [=](const Inputs& in) { return meta_loss(in[0], in[1], x_in, y_in, x_out, y_out); };
  expect_gradcheck("maml meta-loss", f, {randn64({2, 1}, 1), randn64({1}, 2)});
  agtest::expect_gradgradcheck("maml meta-loss", f, {randn64({2, 1}, 3), randn64({1}, 4)});

  // The first-order shortcut (detaching the inner gradient) gives a different answer: the
  // second-order term matters here, so the check above is not vacuous.
  const Tensor w = randn64({2, 1}, 1), b = randn64({1}, 2);
  const Tensor full = ag::grad({meta_loss(w, b, x_in, y_in, x_out, y_out)}, {w})[0];
  const Tensor inner = ag::mse_loss(ag::tanh(ag::matmul(x_in, w) + b), y_in);
  const std::vector<Tensor> g = ag::grad({inner}, {w, b});
  const Tensor first_order =
      ag::grad({ag::mse_loss(ag::tanh(ag::matmul(x_out, w - g[0] * 0.5) + (b - g[1] * 0.5)), y_out)}, {w})[0];
  double diff = 0;
  for (std::int64_t i = 0; i < full.numel(); ++i) diff = std::max(diff, std::abs(full.at(i) - first_order.at(i)));
  EXPECT_GT(diff, 1e-6);
}

}  // namespace
