#include <cmath>

#include "nn_test_util.h"

namespace nntest {
namespace {

TEST(Sequential, ChainsModulesWithIndexNames) {
  ag::Generator g1(38), g2(38), data(39);
  nn::Sequential seq{std::make_shared<nn::Linear>(2, 4, g1), std::make_shared<nn::Tanh>(),
                     std::make_shared<nn::Linear>(4, 1, g1), std::make_shared<nn::Sigmoid>()};
  EXPECT_EQ(seq.size(), 4u);
  EXPECT_THAT(names_of(seq.named_parameters()), ::testing::ElementsAre("0.weight", "0.bias", "2.weight", "2.bias"));
  nn::MLP mlp({2, 4, 1}, "tanh", g2);
  const Tensor x = ag::randn({3, 2}, data);
  EXPECT_LT(max_abs_diff(seq.forward(x), ag::sigmoid(mlp.forward(x))), 1e-6);
  EXPECT_THAT(error_of([&] { (void)seq[9]; }), HasSubstr("out of range"));
  // Cloning a Sequential clones its children.
  auto copy = std::static_pointer_cast<nn::Sequential>(seq.clone());
  EXPECT_NE(copy->parameter("0.weight").impl(), seq.parameter("0.weight").impl());
  EXPECT_LT(max_abs_diff(copy->forward(x), seq.forward(x)), 0.0 + 1e-12);
}

TEST(ModuleList, IndexNamesAndAccess) {
  ag::Generator gen(42);
  nn::ModuleList list;
  list.push_back(std::make_shared<nn::Linear>(2, 3, gen));
  list.push_back(std::make_shared<nn::Tanh>());
  EXPECT_EQ(list.size(), 2u);
  EXPECT_EQ(list.at<nn::Linear>(0).out_features(), 3);
  EXPECT_EQ(list[1].type_name(), "Tanh");
  EXPECT_THAT(names_of(list.named_parameters()), ::testing::ElementsAre("0.weight", "0.bias"));
  EXPECT_THAT(error_of([&] { (void)list[2]; }), HasSubstr("index 2 out of range (size 2)"));
}

}  // namespace
}  // namespace nntest
