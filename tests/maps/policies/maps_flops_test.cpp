#include "maps/policies/maps_flops.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace maps::core {
namespace {

TEST(MapsTrainingStepFlops, CountsThePapersShapesTermByTerm) {
  // Gravity: n = 5 x 128 = 640 states, M = 10.
  //   modules: 2 n M 17 128 x 2 (forward, weight gradient)             = 55,705,600
  //            2 n M 128 128 x 3 (and the input gradient), two layers    = 1,258,291,200
  //   head:    2 n M 128 6 x 3                                           = 29,491,200
  //   selector first layer, state part on 2n rows, x 2: 2 x 2 (2n) 17 128 = 11,141,120
  //   selector 128 -> 128 and 128 -> 10 on (K + 1) n = 3840 rows, x 3    = 377,487,360 + 29,491,200
  const MAPSConfig paper;
  EXPECT_DOUBLE_EQ(maps_training_step_flops({17, 6, 5}, paper, 128),
                   55705600.0 + 1258291200.0 + 29491200.0 + 11141120.0 + 377487360.0 + 29491200.0);
  EXPECT_DOUBLE_EQ(maps_training_step_flops({17, 6, 11}, paper, 128), 4770889728.0);
  EXPECT_DOUBLE_EQ(maps_training_step_flops({39, 4, 10}, paper, 32), 1088716800.0);
}

TEST(MapsTrainingStepFlops, FollowsTheConfigsSizes) {
  // One module layer 2 -> 3, no selector hidden layer (2 + K -> M directly), M = 2, K = 2, A = 1, 1 state per task:
  // modules 2*2*2*2*3*2 = 96, head 3*2*2*2*3*1 = 72, selector state part 2*2*2*2*2*2 = 64, no further selector layer.
  MAPSConfig small;
  small.modules = 2;
  small.module_hidden = {3};
  small.selector_hidden = {};
  EXPECT_DOUBLE_EQ(maps_training_step_flops({2, 1, 2}, small, 1), 96.0 + 72.0 + 64.0);
  EXPECT_THROW(maps_training_step_flops({2, 1, 2}, small, 0), std::invalid_argument);
}

}  // namespace
}  // namespace maps::core
