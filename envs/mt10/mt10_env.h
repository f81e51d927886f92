#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>

#include "envs/mujoco_env.h"

// Meta-World's MT10 (v2) re-created from primitive geoms: a table, a floating two-finger hand welded to a mocap
// body (envs/assets/mt10/scene.xml) and one task's objects (envs/assets/mt10/<task>.xml). Facts:
// ../shared/reference/mt10.md. docs/mt10.md lists where this departs from Meta-World.
//
// Action (4): xyz in [-1, 1] moves the mocap target by action * 0.01 m (clipped to the workspace box
// [-0.5, 0.4, 0.05]..[0.5, 1.0, 0.5]); the 4th entry is the gripper effort (+1 closes, -1 opens).
// Observation (39): hand position, gripper opening, object position, object quaternion, 7 zeros (no second
// object), the same 18 numbers of the previous step (at reset: a copy of the current ones), goal position.
// Reward: 1 at a step where the task's success test holds, else 0 (Meta-World's shaped rewards are not re-created:
// imitation learning does not use them).
namespace maps::envs::mt10 {

struct MT10Options {
  int horizon = 150;            // the paper's code; Meta-World v2 uses 500
  bool end_on_success = false;  // when true, the step where success first holds terminates the episode
};

class MT10Env : public MujocoEnv {
 public:
  static constexpr int kObservationSize = 39;
  static constexpr int kActionSize = 4;
  static constexpr int kFrameSkip = 5;  // dt = 5 x 0.0025 s
  static constexpr double kActionScale = 0.01;
  static constexpr int kFrameSize = 18;  // one step's part of the observation

  const MT10Options& options() const { return options_; }
  Eigen::Vector3d hand_position() const;  // the hand body's origin
  Eigen::Vector3d tcp_center() const;     // midway between the fingertip sites, 0.045 m below the hand
  double gripper_opening() const;         // clip(fingertip distance / 0.1, 0, 1): 1 open, 0.3 closed on nothing
  const Eigen::Vector3d& goal() const { return goal_; }
  // The task's success test on the current state.
  virtual bool is_success() const = 0;

 protected:
  // `objects_file`: the task's bodies, envs/assets/mt10/<objects_file>, put into the scene.
  MT10Env(std::string task, std::int64_t task_index, const std::string& objects_file, Eigen::Vector3d hand_init,
          MT10Options options);

  // Draws the task's random placement from `rng`, places the objects (body positions in the model, joint
  // positions in the data) and calls set_goal(). The hand is already at its initial position, fingers open.
  virtual void place_objects(std::mt19937_64& rng) = 0;
  // The task's object point and orientation (w, x, y, z; zeros where Meta-World reports zeros).
  virtual Eigen::Vector3d object_position() const = 0;
  virtual Eigen::Vector4d object_quaternion() const { return Eigen::Vector4d::Zero(); }

  void set_goal(const Eigen::Vector3d& goal);
  // Lookups by name; a missing name is an error naming the task and the object.
  int body_id(const std::string& name) const;
  int site_id(const std::string& name) const;
  int joint_qpos_address(const std::string& name) const;
  int joint_dof_address(const std::string& name) const;
  Eigen::Vector3d body_position(int body) const;
  Eigen::Vector4d body_quaternion(int body) const;  // (w, x, y, z)
  Eigen::Vector3d site_position(int site) const;
  // Moves a body of the model (a static object's placement) and recomputes positions.
  void set_body_position(int body, const Eigen::Vector3d& position);
  static double uniform(std::mt19937_64& rng, double low, double high);

 private:
  Eigen::VectorXd reset_model(std::mt19937_64& rng) final;
  StepResult step_clipped(const Eigen::VectorXd& action) final;
  Eigen::VectorXd observe();

  MT10Options options_;
  Eigen::Vector3d hand_init_;
  Eigen::Vector3d goal_ = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, kFrameSize, 1> previous_frame_;
  int mocap_ = -1;  // index into data->mocap_pos
  int hand_qpos_ = -1;
  int hand_dof_ = -1;
  int right_finger_qpos_ = -1, left_finger_qpos_ = -1;
  int right_tip_ = -1, left_tip_ = -1;
  int hand_body_ = -1;
  int goal_site_ = -1;
  Eigen::VectorXd ctrl_ = Eigen::VectorXd::Zero(2);
};

// The workspace box of the mocap target.
inline const Eigen::Vector3d kMocapLow{-0.5, 0.4, 0.05};
inline const Eigen::Vector3d kMocapHigh{0.5, 1.0, 0.5};

// The scene with a task's objects, as MJCF text (for tests and tools).
std::string mt10_xml(const std::string& objects_file);

}  // namespace maps::envs::mt10
