#pragma once

#include "envs/mt10/mt10_env.h"

// The puck of reach, push and pick-place (envs/assets/mt10/puck.xml) and its placement.
namespace maps::envs::mt10 {

class PuckEnv : public MT10Env {
 protected:
  PuckEnv(const std::string& task, std::int64_t index, MT10Options options)
      : MT10Env(task, index, "puck.xml", {0.0, 0.6, 0.2}, options),
        puck_(body_id("obj")),
        puck_qpos_(joint_qpos_address("obj_free")) {}

  // Meta-World's draw: the puck at x in [-0.1, 0.1], y in [0.6, 0.7], the goal at x in [-0.1, 0.1], y in
  // [0.8, 0.9], z in [goal_z_low, goal_z_high], redrawn while they are within 0.15 of each other in xy. Places the
  // puck at height `puck_z` and returns the goal.
  Eigen::Vector3d place_puck_and_draw_goal(std::mt19937_64& rng, double goal_z_low, double goal_z_high,
                                           double puck_z = 0.02) {
    Eigen::Vector3d puck, goal;
    do {
      puck = {uniform(rng, -0.1, 0.1), uniform(rng, 0.6, 0.7), puck_z};
      goal = {uniform(rng, -0.1, 0.1), uniform(rng, 0.8, 0.9), uniform(rng, goal_z_low, goal_z_high)};
    } while ((puck.head<2>() - goal.head<2>()).norm() < 0.15);
    Eigen::Map<Eigen::Vector3d>(mutable_data()->qpos + puck_qpos_) = puck;
    return goal;
  }
  Eigen::Vector3d object_position() const override { return body_position(puck_); }
  // Meta-World reports this quaternion as (x, y, z, w) (scipy); every MT10 task here uses MuJoCo's (w, x, y, z).
  Eigen::Vector4d object_quaternion() const override { return body_quaternion(puck_); }

 private:
  int puck_;
  int puck_qpos_;
};

}  // namespace maps::envs::mt10
