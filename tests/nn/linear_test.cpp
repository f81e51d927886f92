#include <cmath>

#include "nn_test_util.h"

namespace nntest {
namespace {

TEST(Linear, ShapesAndPyTorchInitBounds) {
  ag::Generator gen(11);
  nn::Linear lin(16, 64, gen);
  EXPECT_EQ(lin.weight().shape(), (Shape{64, 16}));
  EXPECT_EQ(lin.bias().shape(), (Shape{64}));
  const double bound = 1.0 / std::sqrt(16.0);
  for (const Tensor& t : {lin.weight(), lin.bias()}) {
    const auto v = t.to_vector();
    const double lo = *std::min_element(v.begin(), v.end()), hi = *std::max_element(v.begin(), v.end());
    EXPECT_GE(lo, -bound);
    EXPECT_LE(hi, bound);
    // Spread over the whole interval (1024 weights; 64 biases come within 10% of each end).
    EXPECT_LT(lo, -0.85 * bound);
    EXPECT_GT(hi, 0.85 * bound);
  }
  EXPECT_EQ(lin.parameter_count(), 64 * 16 + 64);
}

TEST(Linear, SameSeedSameInit) {
  ag::Generator g1(12), g2(12);
  nn::Linear a(5, 3, g1), b(5, 3, g2);
  EXPECT_EQ(a.weight().to_vector(), b.weight().to_vector());
  EXPECT_EQ(a.bias().to_vector(), b.bias().to_vector());
}

TEST(Linear, ForwardIsXWtPlusB) {
  ag::Generator gen(13);
  nn::Linear lin(3, 2, gen);
  lin.to(Dtype::Float64);
  const Tensor x = tensor({1, 2, 3, -1, 0.5, 0}, {2, 3});
  const Tensor y = lin.forward(x);
  ASSERT_EQ(y.shape(), (Shape{2, 2}));
  const auto X = ag::to_eigen_double(x), W = ag::to_eigen_double(lin.weight());
  const auto b = ag::to_eigen_double(lin.bias());
  const ag::RowMatrixD expected = (X * W.transpose()).rowwise() + b.row(0);
  EXPECT_LT(max_abs_diff(y, ag::from_eigen(expected)), 1e-12);
  // 3-d input [b, n, in] -> [b, n, out].
  EXPECT_EQ(lin.forward(ag::zeros({4, 5, 3}, Dtype::Float64)).shape(), (Shape{4, 5, 2}));
}

TEST(Linear, WithoutBias) {
  ag::Generator gen(14);
  nn::Linear lin(3, 2, gen, /*bias=*/false);
  EXPECT_THAT(names_of(lin.named_parameters()), ::testing::ElementsAre("weight"));
  EXPECT_EQ(max_abs_diff(lin.forward(ag::zeros({1, 3})), ag::zeros({1, 2})), 0.0);
  EXPECT_THAT(error_of([&] { (void)lin.bias(); }), HasSubstr("without bias"));
}

TEST(Linear, BadInputNamesTheShapes) {
  ag::Generator gen(15);
  nn::Linear lin(3, 2, gen);
  EXPECT_THAT(error_of([&] {
                lin.forward(ag::zeros({4, 5}));
              }),
              ::testing::AllOf(HasSubstr("Linear(3, 2)"), HasSubstr("[4, 5]")));
  EXPECT_THAT(error_of([&] { nn::Linear(0, 2, gen); }), HasSubstr("must be positive"));
}

TEST(Linear, Gradcheck) {
  ag::Generator gen(16);
  nn::Linear lin(3, 4, gen);
  lin.to(Dtype::Float64);
  ag::Generator data(17);
  const Tensor x = ag::randn({5, 3}, data, Dtype::Float64).requires_grad_();
  // The function reads the module's slots, which gradcheck perturbs in place.
  const auto result = ag::gradcheck("Linear", [&](const std::vector<Tensor>& in) { return lin.forward(in[0]); },
                                    {x, lin.weight(), lin.bias()});
  EXPECT_TRUE(result.ok) << result.message;
}

}  // namespace
}  // namespace nntest
