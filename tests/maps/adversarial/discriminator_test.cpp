#include "maps/adversarial/discriminator.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "autograd/gradcheck.h"
#include "maps/adversarial/discriminator_loss.h"

namespace maps::adversarial {
namespace {

using ag::Dtype;
using ag::Tensor;

double softplus(double x) { return std::log1p(std::exp(-std::abs(x))) + std::max(x, 0.0); }
double sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

// S = 2, A = 1, K = 2, one hidden layer of 3 (tanh): small enough to write its forward pass and the gradient of the
// logit in its inputs by hand.
struct Fixture {
  static constexpr int S = 2, A = 1, K = 2, H = 3;
  ag::Generator gen{7};
  Discriminator d;
  explicit Fixture(const std::string& conditioning) : d(DiscriminatorConfig{{H}, "tanh", conditioning}, S, A, K, gen) {
    d.to(Dtype::Float64);
  }

  Eigen::MatrixXd weight(int layer) const {
    return ag::to_eigen_double(d.parameter("mlp.layers." + std::to_string(layer) + ".weight"));
  }
  Eigen::VectorXd bias(int layer) const {
    return ag::to_eigen_double(d.parameter("mlp.layers." + std::to_string(layer) + ".bias")).reshaped();
  }
  // The network's input for pair x of task k.
  Eigen::VectorXd input(const Eigen::VectorXd& x, int k) const {
    if (d.config().conditioning == "heads") return x;
    Eigen::VectorXd in(S + A + K);
    in << x, Eigen::VectorXd::Unit(K, k);
    return in;
  }
  // logit(x, k) and its gradient in x, by hand.
  std::pair<double, Eigen::VectorXd> logit(const Eigen::VectorXd& x, int k) const {
    const Eigen::MatrixXd W0 = weight(0), W1 = weight(1);
    const Eigen::VectorXd h = (W0 * input(x, k) + bias(0)).array().tanh();
    const int row = d.config().conditioning == "heads" ? k : 0;
    const double value = W1.row(row).dot(h) + bias(1)(row);
    const Eigen::VectorXd dh = W1.row(row).transpose().array() * (1.0 - h.array().square());
    const Eigen::VectorXd grad_input = W0.transpose() * dh;
    return {value, grad_input.head(S + A)};
  }
};

Tensor matrix_tensor(const std::vector<double>& values, std::int64_t rows, std::int64_t cols) {
  return ag::from_vector(values, {rows, cols}, Dtype::Float64);
}

class DiscriminatorByHand : public ::testing::TestWithParam<std::string> {};

TEST_P(DiscriminatorByHand, LossTermsEqualAHandComputation) {
  Fixture f(GetParam());
  const std::vector<std::int64_t> tasks{0, 1, 1};
  const Tensor expert = matrix_tensor({0.3, -0.2, 0.5, 1.0, 0.4, -0.7, -0.6, 0.1, 0.9}, 3, 3);
  const Tensor policy = matrix_tensor({-0.4, 0.8, -0.1, 0.2, -0.9, 0.6, 0.7, 0.5, -0.3}, 3, 3);
  const Tensor mix = ag::from_vector(std::vector<double>{0.25, 0.5, 0.9}, {3}, Dtype::Float64);
  const DiscriminatorLoss loss =
      discriminator_loss(f.d, expert, policy, tasks, DiscriminatorLossConfig{10.0, 0.01}, mix);

  const Eigen::MatrixXd E = ag::to_eigen_double(expert), P = ag::to_eigen_double(policy);
  double cross_entropy = 0.0, entropy = 0.0, penalty = 0.0, expert_right = 0.0, policy_right = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double le = f.logit(E.row(i).transpose(), static_cast<int>(tasks[i])).first;
    const double lp = f.logit(P.row(i).transpose(), static_cast<int>(tasks[i])).first;
    cross_entropy += (-std::log(sigmoid(le)) - std::log(1.0 - sigmoid(lp))) / 6.0;
    for (const double l : {le, lp}) {
      const double p = sigmoid(l);
      entropy += (-p * std::log(p) - (1.0 - p) * std::log(1.0 - p)) / 6.0;
    }
    expert_right += le > 0.0 ? 1.0 / 3.0 : 0.0;
    policy_right += lp < 0.0 ? 1.0 / 3.0 : 0.0;
    const double u = mix.at(i);
    const Eigen::VectorXd point = u * E.row(i).transpose() + (1.0 - u) * P.row(i).transpose();
    const double norm = f.logit(point, static_cast<int>(tasks[i])).second.norm();
    penalty += (norm - 1.0) * (norm - 1.0) / 3.0;
  }
  EXPECT_NEAR(loss.cross_entropy.item(), cross_entropy, 1e-12);
  EXPECT_NEAR(loss.entropy.item(), entropy, 1e-12);
  EXPECT_NEAR(loss.penalty.item(), penalty, 1e-10);
  EXPECT_NEAR(loss.total.item(), cross_entropy - 0.01 * entropy + 10.0 * penalty, 1e-9);
  EXPECT_DOUBLE_EQ(loss.expert_accuracy, expert_right);
  EXPECT_DOUBLE_EQ(loss.policy_accuracy, policy_right);
}

// The loss's gradient in every parameter against central differences, the penalty's (a gradient of a gradient)
// included.
TEST_P(DiscriminatorByHand, GradientsMatchNumericalOnesPenaltyIncluded) {
  Fixture f(GetParam());
  const std::vector<std::int64_t> tasks{1, 0};
  const Tensor expert = matrix_tensor({0.3, -0.2, 0.5, 1.0, 0.4, -0.7}, 2, 3);
  const Tensor policy = matrix_tensor({-0.4, 0.8, -0.1, 0.2, -0.9, 0.6}, 2, 3);
  const Tensor mix = ag::from_vector(std::vector<double>{0.3, 0.8}, {2}, Dtype::Float64);
  std::vector<std::string> names;
  std::vector<Tensor> inputs;
  for (const auto& [name, tensor] : f.d.named_parameters()) {
    names.push_back(name);
    inputs.push_back(tensor.detach().requires_grad_(true));
  }
  for (const DiscriminatorLossConfig config :
       {DiscriminatorLossConfig{0.0, 0.0}, DiscriminatorLossConfig{10.0, 0.05}}) {
    const ag::SingleFunction loss_of = [&](const std::vector<Tensor>& params) {
      for (std::size_t i = 0; i < names.size(); ++i) f.d.replace_parameter(names[i], params[i]);
      return discriminator_loss(f.d, expert, policy, tasks, config, mix).total;
    };
    const auto result = ag::gradcheck("discriminator_loss", loss_of, inputs);
    EXPECT_TRUE(result.ok) << result.message;
  }
}

INSTANTIATE_TEST_SUITE_P(Conditioning, DiscriminatorByHand, ::testing::Values("input", "heads"));

TEST(GailReward, EachKindIsItsFormulaOfD) {
  const std::vector<double> logits{-30.0, -2.0, 0.0, 0.7, 25.0};
  const Tensor l = ag::from_vector(logits, {5}, Dtype::Float64);
  const auto gail = gail_reward(l, "gail").to_vector();
  const auto log_d = gail_reward(l, "log_d").to_vector();
  const auto raw = gail_reward(l, "logit").to_vector();
  for (std::size_t i = 0; i < logits.size(); ++i) {
    const double D = sigmoid(logits[i]);
    EXPECT_NEAR(gail[i], softplus(logits[i]), 1e-12);
    if (D < 1.0 - 1e-9) {
      EXPECT_NEAR(gail[i], -std::log(1.0 - D), 1e-9 * std::max(1.0, gail[i]));
    }
    EXPECT_GT(gail[i], 0.0);
    EXPECT_NEAR(log_d[i], std::log(D), 1e-9 * std::max(1.0, std::abs(log_d[i])));
    EXPECT_DOUBLE_EQ(raw[i], logits[i]);
  }
  EXPECT_THROW(gail_reward(l, "airl"), std::invalid_argument);
}

TEST(Discriminator, RefusesWhatItCannotScore) {
  ag::Generator gen(1);
  EXPECT_THROW(Discriminator(DiscriminatorConfig{{}, "tanh", "input"}, 2, 1, 2, gen), std::invalid_argument);
  EXPECT_THROW(Discriminator(DiscriminatorConfig{{8}, "gelu", "input"}, 2, 1, 2, gen), std::invalid_argument);
  EXPECT_THROW(Discriminator(DiscriminatorConfig{{8}, "tanh", "task"}, 2, 1, 2, gen), std::invalid_argument);
  Discriminator d(DiscriminatorConfig{{8}, "tanh", "input"}, 2, 1, 2, gen);
  EXPECT_THROW(d.logits(ag::zeros({3, 2}), ag::zeros({3, 2}), {0, 1, 0}), std::invalid_argument);  // action width
  EXPECT_THROW(d.logits(ag::zeros({3, 2}), ag::zeros({3, 1}), {0, 1}), std::invalid_argument);     // task count
  EXPECT_THROW(d.logits(ag::zeros({2, 2}), ag::zeros({2, 1}), {0, 2}), std::invalid_argument);     // task id
  EXPECT_EQ(d.logits(ag::zeros({2, 2}), ag::zeros({2, 1}), {0, 1}).shape(), ag::Shape({2}));
  const Tensor pairs = ag::zeros({2, 3});
  EXPECT_THROW(discriminator_loss(d, pairs, ag::zeros({3, 3}), {0, 1}, {}, ag::zeros({2})), std::invalid_argument);
  EXPECT_THROW(discriminator_loss(d, pairs, pairs, {0, 1}, {}, ag::zeros({3})), std::invalid_argument);
  EXPECT_THROW(discriminator_loss(d, pairs, pairs, {0, 1}, DiscriminatorLossConfig{-1.0, 0.0}, ag::zeros({2})),
               std::invalid_argument);
}

}  // namespace
}  // namespace maps::adversarial
