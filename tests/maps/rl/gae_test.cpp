#include "maps/rl/gae.h"

#include "rl_test_util.h"

namespace rltest {
namespace {

// gamma 0.9, lambda 0.8. Step 1 is truncated (bootstrap from the final observation's value 10), step 3
// terminated (its next value, 99, must be ignored).
//   deltas: 1 + 0.9*1 - 0.5 = 1.4 | 2 + 0.9*10 - 1 = 10 | 3 + 0.9*2 - 1.5 = 3.3 | 4 - 2 = 2
//   A3 = 2, A2 = 3.3 + 0.72*2 = 4.74, A1 = 10 (episode end), A0 = 1.4 + 0.72*10 = 8.6
TEST(Gae, HandComputedWithTruncationAndTerminal) {
  const Eigen::Vector4d rewards(1, 2, 3, 4), values(0.5, 1.0, 1.5, 2.0), next_values(1.0, 10.0, 2.0, 99.0);
  const auto r = maps::rl::compute_gae(rewards, values, next_values, {false, false, false, true},
                                       {false, true, false, true}, 0.9, 0.8);
  const Eigen::Vector4d expected(8.6, 10.0, 4.74, 2.0);
  EXPECT_LT((r.advantages - expected).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((r.returns - (expected + values)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Gae, RolloutEndBootstrapsAndLambdaOneGivesDiscountedReturns) {
  // No episode end: the last step bootstraps from next_values(2) = 4; with lambda 1 the return is the
  // discounted sum of rewards plus gamma^3 * 4.
  const Eigen::Vector3d rewards(1, 1, 1), values(0.3, -0.2, 0.7), next_values(-0.2, 0.7, 4.0);
  const auto r =
      maps::rl::compute_gae(rewards, values, next_values, {false, false, false}, {false, false, false}, 0.5, 1.0);
  EXPECT_NEAR(r.returns(0), 1 + 0.5 + 0.25 + 0.125 * 4.0, 1e-12);
  EXPECT_NEAR(r.returns(2), 1 + 0.5 * 4.0, 1e-12);
  EXPECT_THROW(
      maps::rl::compute_gae(rewards, values, next_values, {true, false, false}, {false, false, false}, 0.5, 1.0),
      std::invalid_argument);
}

}  // namespace
}  // namespace rltest
