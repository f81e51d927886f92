// Selector losses from outside the paper's four: registered by name (MAPS_REGISTER_SELECTOR_LOSS, as a program's own
// file or a plugin does), used by name, and refused when the name is taken or not plain (issue 43).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "autograd/autograd.h"
#include "io/registry.h"
#include "maps/selector/selector_loss.h"

namespace maps::core {
namespace {

using ::testing::HasSubstr;

// The mean square of the scores: a loss written outside maps/selector/, as a user's would be.
class MeanSquareLoss : public SelectorLoss {
 public:
  MeanSquareLoss() : SelectorLoss("MeanSquareLoss") {}
  std::string name() const override { return "test_mean_square"; }
  ag::Tensor forward(const SelectorOutputs& out) override { return ag::mean(out.scores * out.scores); }

 protected:
  std::shared_ptr<nn::Module> shallow_copy() const override { return std::make_shared<MeanSquareLoss>(*this); }
};

MAPS_REGISTER_SELECTOR_LOSS("test_mean_square", [] { return std::make_shared<MeanSquareLoss>(); });

TEST(SelectorRegistry, ARegisteredLossFollowsTheBuiltInsAndIsMadeByName) {
  // After the four built-ins (selector_loss_test.cpp checks them), the test program's own: this file's and
  // task_entropy_loss_example.cpp's, in either order.
  const auto& losses = selector_losses();
  ASSERT_GE(losses.size(), 6u);
  EXPECT_EQ(losses[3].name, "smooth");
  std::vector<std::string> added;
  for (std::size_t i = 4; i < losses.size(); ++i) added.push_back(losses[i].name);
  EXPECT_THAT(added, ::testing::IsSupersetOf({"test_mean_square", "task_entropy"}));
  const auto loss = make_selector_loss("test_mean_square");
  SelectorOutputs out;
  out.scores = ag::from_vector(std::vector<double>{0.5, 0.5, 1.0, 0.0}, {2, 2}, ag::Dtype::Float64);
  EXPECT_DOUBLE_EQ(loss->forward(out).item(), (0.25 + 0.25 + 1.0) / 4);
  EXPECT_EQ(selector_loss_origin("test_mean_square"), "");  // the program's own
  EXPECT_EQ(selector_loss_origin("share"), "");
  EXPECT_THAT(selector_loss_names(), HasSubstr("share, explore, sparse, smooth, "));
}

// docs/selector-losses.md's example: each task's usage spread evenly over M = 2 modules is the minimum, -log 2.
TEST(SelectorRegistry, TheDocsExampleLossSpreadsEachTasksUsage) {
  const auto loss = make_selector_loss("task_entropy");
  SelectorOutputs out;
  out.num_tasks = 3;  // task 2 has no state in the batch: it does not count
  out.num_modules = 2;
  out.tasks = {0, 1, 0, 1};
  // Task 0: rows (0.9, 0.1) and (0.1, 0.9), usage (0.5, 0.5); task 1: (1, 0) twice, usage (1, 0).
  out.scores = ag::from_vector(std::vector<double>{0.9, 0.1, 1.0, 0.0, 0.1, 0.9, 1.0, 0.0}, {4, 2}, ag::Dtype::Float64);
  EXPECT_NEAR(loss->forward(out).item(), (-std::log(2.0) + 0.0) / 2, 1e-12);
}

TEST(SelectorRegistry, ATakenOrUnplainNameIsRefusedNamingWhoHasIt) {
  const auto make = [] { return std::make_shared<MeanSquareLoss>(); };
  const std::size_t size_before = selector_losses().size();
  {
    const io::LoadingOrigin plugin("/tmp/libmine.so");
    EXPECT_THAT([&] { register_selector_loss("share", make); },
                ::testing::ThrowsMessage<std::invalid_argument>(
                    ::testing::AllOf(HasSubstr("selector loss 'share' from plugin /tmp/libmine.so"), HasSubstr("taken"),
                                     HasSubstr("built-in"))));
    EXPECT_THAT([&] { register_selector_loss("test_mean_square", make); },
                ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("taken")));
    for (const std::string& bad :
         std::vector<std::string>{"", "Share", "two words", "a-b", "9lives", std::string(65, 'a')})
      EXPECT_THAT([&] { register_selector_loss(bad, make); },
                  ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("a name is a lowercase letter")))
          << bad;
    EXPECT_THAT([&] { register_selector_loss("no_factory", nullptr); },
                ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("no factory")));
  }
  EXPECT_EQ(selector_losses().size(), size_before);  // nothing refused was added
}

TEST(SelectorRegistry, APluginsLossRecordsWhereItCameFrom) {
  {
    const io::LoadingOrigin plugin("/opt/plugins/libextra.so");
    register_selector_loss("test_from_plugin", [] { return std::make_shared<MeanSquareLoss>(); });
  }
  EXPECT_EQ(selector_loss_origin("test_from_plugin"), "/opt/plugins/libextra.so");
  EXPECT_EQ(io::loading_origin(), "");  // restored
}

// A registration refused while a program starts cannot throw there: it is recorded, and taken by the loader.
TEST(SelectorRegistry, ARefusalAtStartIsRecordedNotThrown) {
  EXPECT_TRUE(io::register_at_start([] { register_selector_loss("share", [] { return make_share_loss(); }); }));
  const std::vector<std::string> errors = io::take_registration_errors();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_THAT(errors[0], HasSubstr("selector loss 'share'"));
  EXPECT_TRUE(io::take_registration_errors().empty());
}

}  // namespace
}  // namespace maps::core
