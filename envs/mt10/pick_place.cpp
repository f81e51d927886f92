// pick-place: grasp the puck and carry it to within 7 cm of a goal in the air.

#include <cmath>
#include <memory>

#include "envs/mt10/puck_env.h"
#include "envs/mt10/tasks.h"

namespace maps::envs::mt10 {
namespace {

class PickPlaceEnv : public PuckEnv {
 public:
  PickPlaceEnv(const std::string& task, std::int64_t index, MT10Options options) : PuckEnv(task, index, options) {}

  bool is_success() const override { return (object_position() - goal()).norm() <= 0.07; }

 protected:
  void place_objects(std::mt19937_64& rng) override { set_goal(place_puck_and_draw_goal(rng, 0.05, 0.3)); }
};

std::unique_ptr<MT10Env> make_pick_place(const std::string& task, std::int64_t index, MT10Options options) {
  return std::make_unique<PickPlaceEnv>(task, index, options);
}

// Hover, descend around the puck, hold still until the fingers have closed on it, then carry it: the hand goes
// to the goal itself and the puck hangs about 3 cm below, inside the 7 cm tolerance.
Eigen::Vector4d pick_place_expert(const Eigen::VectorXd& obs) {
  const Eigen::Vector3d hand = obs_hand(obs);
  const Eigen::Vector3d puck = obs_object(obs);
  const Eigen::Vector3d aim = puck + Eigen::Vector3d(-0.005, 0.0, 0.0);
  Eigen::Vector3d target;
  if ((hand.head<2>() - aim.head<2>()).norm() > 0.02) {
    target = aim + Eigen::Vector3d(0.0, 0.0, 0.1);
  } else if (std::abs(hand.z() - aim.z()) > 0.05 && aim.z() < 0.04) {
    target = aim + Eigen::Vector3d(0.0, 0.0, 0.03);
  } else if (obs_gripper(obs) > 0.73) {
    target = hand;  // the fingers are still closing
  } else {
    target = obs_goal(obs);
  }
  const double grab = (hand - puck).norm() < 0.07 ? 1.0 : 0.0;
  return expert_action(move_toward(hand, target, 10.0), grab);
}

const MT10TaskRegistration pick_place_registration({"pick-place", 2, make_pick_place, pick_place_expert, 1.0});

}  // namespace

}  // namespace maps::envs::mt10
