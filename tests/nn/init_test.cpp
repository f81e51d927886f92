#include <cmath>
#include <numeric>

#include "nn_test_util.h"

namespace nntest {
namespace {

namespace init = nn::init;

TEST(Init, FanInAndFanOut) {
  EXPECT_EQ(init::fan_in_and_fan_out(ag::zeros({5, 3})), (std::pair<std::int64_t, std::int64_t>{3, 5}));
  EXPECT_EQ(init::fan_in_and_fan_out(ag::zeros({5, 3, 2, 2})), (std::pair<std::int64_t, std::int64_t>{12, 20}));
  EXPECT_THAT(error_of([] { init::fan_in_and_fan_out(ag::zeros({4})); }), HasSubstr("at least 2 dims"));
}

TEST(Init, KaimingUniformBound) {
  ag::Generator gen(51);
  Tensor w = ag::zeros({200, 50});
  init::kaiming_uniform_(w, gen, std::sqrt(5.0));
  const auto v = w.to_vector();
  const double bound = 1.0 / std::sqrt(50.0);
  EXPECT_LE(*std::max_element(v.begin(), v.end()), bound);
  EXPECT_GE(*std::min_element(v.begin(), v.end()), -bound);
  EXPECT_GT(*std::max_element(v.begin(), v.end()), 0.99 * bound);
  // a = 0 (ReLU gain): bound sqrt(6 / fan_in); fan_out mode uses the other dim.
  init::kaiming_uniform_(w, gen, 0.0, init::FanMode::FanOut);
  const auto u = w.to_vector();
  EXPECT_LE(*std::max_element(u.begin(), u.end()), std::sqrt(6.0 / 200.0));
  EXPECT_GT(*std::max_element(u.begin(), u.end()), 0.99 * std::sqrt(6.0 / 200.0));
}

TEST(Init, UniformNormalConstant) {
  ag::Generator gen(52);
  Tensor t = ag::zeros({100, 100}, Dtype::Float64);
  init::normal_(t, 1.5, 2.0, gen);
  const auto v = t.to_vector();
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
  double var = 0.0;
  for (double x : v) var += (x - mean) * (x - mean);
  var /= v.size();
  EXPECT_NEAR(mean, 1.5, 0.06);
  EXPECT_NEAR(std::sqrt(var), 2.0, 0.06);
  init::uniform_(t, -3.0, -2.0, gen);
  for (double x : t.to_vector()) ASSERT_TRUE(x >= -3.0 && x < -2.0);
  init::constant_(t, 0.25);
  for (double x : t.to_vector()) ASSERT_EQ(x, 0.25);
  init::zeros_(t);
  for (double x : t.to_vector()) ASSERT_EQ(x, 0.0);
  EXPECT_THAT(error_of([&] { init::uniform_(t, 1.0, 0.0, gen); }), HasSubstr("must not exceed"));
  EXPECT_THAT(error_of([&] { init::normal_(t, 0.0, -1.0, gen); }), HasSubstr("std must be >= 0"));
}

TEST(Init, WorksOnParametersThatRequireGrad) {
  ag::Generator gen(53);
  Tensor w = ag::zeros({3, 3}).requires_grad_();
  init::xavier_uniform_(w, gen);
  EXPECT_TRUE(w.is_leaf());
  EXPECT_TRUE(w.requires_grad());
  for (double x : w.to_vector()) EXPECT_LE(std::abs(x), 1.0);  // sqrt(6 / 6)
}

TEST(Init, SameSeedSameValues) {
  ag::Generator g1(54), g2(54);
  Tensor a = ag::zeros({4, 4}), b = ag::zeros({4, 4});
  init::orthogonal_(a, 1.0, g1);
  init::orthogonal_(b, 1.0, g2);
  EXPECT_EQ(a.to_vector(), b.to_vector());
}

// W^T W = gain^2 I for a tall matrix, W W^T = gain^2 I for a wide one, square included.
TEST(Init, OrthogonalIsOrthogonal) {
  const double gain = std::sqrt(2.0);
  for (const Shape& shape : {Shape{6, 4}, Shape{4, 4}, Shape{3, 5}}) {
    ag::Generator gen(55);
    Tensor w = ag::zeros(shape, Dtype::Float64);
    init::orthogonal_(w, gain, gen);
    const ag::RowMatrixD m = ag::to_eigen_double(w);
    const Eigen::MatrixXd gram =
        shape[0] >= shape[1] ? Eigen::MatrixXd(m.transpose() * m) : Eigen::MatrixXd(m * m.transpose());
    const Eigen::MatrixXd expected = gain * gain * Eigen::MatrixXd::Identity(gram.rows(), gram.cols());
    EXPECT_LT((gram - expected).cwiseAbs().maxCoeff(), 1e-12) << ag::to_string(shape);
  }
  // float32 too, to float precision.
  ag::Generator gen(56);
  Tensor w = ag::zeros({8, 8});
  init::orthogonal_(w, 1.0, gen);
  const ag::RowMatrixF m = ag::to_eigen_float(w);
  EXPECT_LT((m.transpose() * m - Eigen::MatrixXf::Identity(8, 8)).cwiseAbs().maxCoeff(), 1e-5);
}

TEST(Init, CalculateGain) {
  EXPECT_DOUBLE_EQ(init::calculate_gain("tanh"), 5.0 / 3.0);
  EXPECT_DOUBLE_EQ(init::calculate_gain("relu"), std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(init::calculate_gain("leaky_relu", std::sqrt(5.0)), std::sqrt(1.0 / 3.0));
  EXPECT_THAT(error_of([] { init::calculate_gain("gelu"); }), HasSubstr("\"gelu\""));
}

}  // namespace
}  // namespace nntest
