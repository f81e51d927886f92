#include "nn_test_util.h"

namespace nntest {
namespace {

TEST(ClipGradNorm, ScalesWhenAboveMaxNorm) {
  Tensor a = ag::zeros({2}).requires_grad_(), b = ag::zeros({1, 2}, Dtype::Float64).requires_grad_();
  Tensor unused = ag::zeros({3}).requires_grad_();  // no grad: skipped
  a.set_grad(tensor({3.0, 0.0}, {2}, Dtype::Float32));
  b.set_grad(tensor({0.0, -4.0}, {1, 2}));
  const double total = nn::clip_grad_norm_({a, b, unused}, 1.0);
  EXPECT_DOUBLE_EQ(total, 5.0);
  const double coef = 1.0 / (5.0 + 1e-6);
  EXPECT_NEAR(a.grad().at(0), 3.0 * coef, 1e-7);
  EXPECT_NEAR(b.grad().at(1), -4.0 * coef, 1e-15);
  EXPECT_NEAR(nn::grad_norm({a, b}), 1.0, 1e-6);
  EXPECT_FALSE(unused.grad().defined());
}

TEST(ClipGradNorm, LeavesSmallGradientsAlone) {
  Tensor a = ag::zeros({2}, Dtype::Float64).requires_grad_();
  a.set_grad(tensor({0.3, 0.4}, {2}));
  EXPECT_DOUBLE_EQ(nn::clip_grad_norm_({a}, 1.0), 0.5);
  EXPECT_EQ(a.grad().to_vector(), (std::vector<double>{0.3, 0.4}));
  EXPECT_THAT(error_of([&] { nn::clip_grad_norm_({a}, -1.0); }), HasSubstr("max_norm"));
}

TEST(ClipGradNorm, AfterBackward) {
  ag::Generator gen(61);
  nn::Linear lin(4, 3, gen);
  ag::sum(ag::square(lin.forward(ag::full({8, 4}, 10.0)))).backward();
  const double before = nn::grad_norm(lin.parameters());
  EXPECT_GT(before, 1.0);
  EXPECT_DOUBLE_EQ(nn::clip_grad_norm_(lin.parameters(), 0.5), before);
  EXPECT_NEAR(nn::grad_norm(lin.parameters()), 0.5, 1e-5);
}

}  // namespace
}  // namespace nntest
