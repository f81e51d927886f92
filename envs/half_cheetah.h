#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <random>
#include <string>

#include "envs/mujoco_env.h"

// HalfCheetah (Gym's, re-created for MuJoCo 2.2.2 in envs/assets/half_cheetah.xml) and its task
// variants from gym-extensions: gravity scaled, or named geoms scaled in size. Facts:
// ../shared/reference/cheetah.md sections 1, 2 and 5.
namespace maps::envs {

struct HalfCheetahVariant {
  double gravity_scale = 1.0;  // gravity z = -9.81 * gravity_scale
  // Geom name -> factor applied to every number of its `size` attribute before compiling: radius
  // and half-length of the pos+axisangle capsules, the radius alone for the fromto torso. The
  // compiler then recomputes masses from the new volumes and renormalises the robot to 14 kg.
  std::map<std::string, double> geom_size_scale;
};

// The MJCF text with the variant's geom sizes applied (gravity is set on the compiled model).
// Throws naming the geom if a name is not found or its size cannot be parsed.
std::string half_cheetah_xml(const HalfCheetahVariant& variant);

class HalfCheetahEnv : public MujocoEnv {
 public:
  static constexpr int kObservationSize = 17;  // qpos[1:9] (rootz, rooty, 6 joints) ++ qvel[0:9]
  static constexpr int kActionSize = 6;        // bthigh, bshin, bfoot, fthigh, fshin, ffoot
  static constexpr int kFrameSkip = 5;         // dt = 5 x 0.01 s
  static constexpr int kHorizon = 1000;
  static constexpr double kCtrlCostWeight = 0.1;
  static constexpr double kResetNoiseScale = 0.1;
  static constexpr double kStandardGravity = 9.81;

  HalfCheetahEnv(std::string task, std::int64_t task_index, HalfCheetahVariant variant = {});

  const HalfCheetahVariant& variant() const { return variant_; }
  Eigen::VectorXd observation() const;
  double x_position() const;  // qpos[0], the rootx slide: the torso frame's origin, not the COM
  double pitch() const;       // qpos[2], the rooty hinge; 0 upright, +-pi on its back (unbounded)
  // True when the torso is upside down, cos(pitch) < 0 (|pitch| past 90 degrees, modulo full
  // turns). A running gait pitches well within +-1 rad, while PPO's "running on its back" trap
  // sits near +-pi, so the quarter turn separates them with a wide margin on both sides.
  bool is_flipped() const;
  bool in_failure_state() const override { return is_flipped(); }

 protected:
  Eigen::VectorXd reset_model(std::mt19937_64& rng) override;
  StepResult step_clipped(const Eigen::VectorXd& action) override;
  double control_cost_weight() const override;

 private:
  HalfCheetahVariant variant_;
};

}  // namespace maps::envs
