#include <cmath>

#include "nn_test_util.h"

namespace nntest {
namespace {

TEST(Activation, ModulesAndNames) {
  const Tensor x = tensor({-1.0, 0.5}, {1, 2});
  EXPECT_LT(max_abs_diff(nn::ReLU().forward(x), tensor({0.0, 0.5}, {1, 2})), 1e-15);
  EXPECT_LT(max_abs_diff(nn::Tanh().forward(x), tensor({std::tanh(-1.0), std::tanh(0.5)}, {1, 2})), 1e-15);
  EXPECT_LT(max_abs_diff(nn::Identity().forward(x), x), 1e-15);
  EXPECT_LT(max_abs_diff(nn::Mish().forward(x), ag::mish(x)), 1e-15);
  for (const char* name : {"identity", "tanh", "relu", "sigmoid", "mish"})
    EXPECT_EQ(nn::to_string(nn::activation_from_name(name)), name);
  EXPECT_LT(max_abs_diff(nn::make_activation(nn::Activation::Sigmoid)->forward(x), ag::sigmoid(x)), 1e-15);
}

TEST(Activation, FusedIntoLayerOpsOnlyWhereTheOpsCanRunIt) {
  EXPECT_EQ(nn::fused_activation(nn::Activation::Tanh), maps::ag::Fused::Tanh);
  EXPECT_EQ(nn::fused_activation(nn::Activation::Identity), maps::ag::Fused::None);
  EXPECT_FALSE(nn::fused_activation(nn::Activation::ReLU).has_value());
  EXPECT_FALSE(nn::fused_activation(nn::Activation::Sigmoid).has_value());
  EXPECT_FALSE(nn::fused_activation(nn::Activation::Mish).has_value());
}

}  // namespace
}  // namespace nntest
