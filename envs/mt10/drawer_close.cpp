// drawer-close: push an open drawer back into its case.

#include <cmath>
#include <memory>

#include "envs/mt10/tasks.h"

namespace maps::envs::mt10 {
namespace {

constexpr double kOpenedSlide = -0.15;  // the drawer starts pulled out this far

class DrawerCloseEnv : public MT10Env {
 public:
  DrawerCloseEnv(const std::string& task, std::int64_t index, MT10Options options)
      : MT10Env(task, index, "drawer.xml", {0.0, 0.6, 0.2}, options),
        drawer_(body_id("drawer")),
        drawer_link_(body_id("drawer_link")),
        slide_qpos_(joint_qpos_address("goal_slidey")) {}

  // Meta-World's 0.05 + 0.015 (its class constant 0.04 is never read). The error is sqrt((q - 0.01)^2 + 0.05^2),
  // so success means the drawer is within about 3 cm of closed (q >= -0.0315).
  bool is_success() const override { return (object_position() - goal()).norm() <= 0.065; }

 protected:
  void place_objects(std::mt19937_64& rng) override {
    const Eigen::Vector3d drawer{uniform(rng, -0.1, 0.1), 0.9, 0.0};
    mutable_data()->qpos[slide_qpos_] = kOpenedSlide;
    set_body_position(drawer_, drawer);
    set_goal(drawer + Eigen::Vector3d(0.0, -0.16, 0.09));
  }
  // Above the front of the handle; Meta-World places it 5 cm higher than drawer-open's point.
  Eigen::Vector3d object_position() const override {
    return body_position(drawer_link_) + Eigen::Vector3d(0.0, -0.16, 0.05);
  }
  // The quaternion: Meta-World reports zeros for this task, the base class's default.

 private:
  int drawer_;
  int drawer_link_;
  int slide_qpos_;
};

std::unique_ptr<MT10Env> make_drawer_close(const std::string& task, std::int64_t index, MT10Options options) {
  return std::make_unique<DrawerCloseEnv>(task, index, options);
}

// The hand starts beyond the handle (farther from the robot than it), so it first rises high, comes over to the
// robot's side of the handle, drops down in front of it and pushes it home with a closed fist. Once the drawer is
// shut the target (1 mm short of the crossbar, which the closed pad cannot reach) keeps the mocap creeping forward
// and the push grows by about 120 N a step; near step 148 (about 10 kN) the pad slips past the crossbar. The
// drawer stays shut: success holds to the end.
Eigen::Vector4d drawer_close_expert(const Eigen::VectorXd& obs) {
  const Eigen::Vector3d hand = obs_hand(obs);
  const Eigen::Vector3d handle = obs_object(obs) + Eigen::Vector3d(0.0, 0.0, -0.02);
  Eigen::Vector3d target;
  if (hand.y() > handle.y()) {
    if (hand.z() < handle.z() + 0.23) {
      target = {hand.x(), hand.y(), handle.z() + 0.5};
    } else {
      target = handle + Eigen::Vector3d(0.0, -0.075, 0.23);
    }
  } else if (std::abs(hand.z() - handle.z()) > 0.04) {
    target = handle + Eigen::Vector3d(0.0, -0.075, 0.0);
  } else {
    target = handle;
  }
  return expert_action(move_toward(hand, target, 25.0), 1.0);
}

const MT10TaskRegistration drawer_close_registration({"drawer-close", 5, make_drawer_close, drawer_close_expert, 1.0});

}  // namespace

}  // namespace maps::envs::mt10
