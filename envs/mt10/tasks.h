#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "envs/mt10/mt10_env.h"

// The ten MT10 tasks in Meta-World's order, each with its scripted expert: a pure function of the observation
// following Meta-World's policy for the task (../shared/reference/mt10.md section 3). One file per task.
namespace maps::envs::mt10 {

using ScriptedExpert = Eigen::Vector4d (*)(const Eigen::VectorXd& observation);
using MT10Factory = std::unique_ptr<MT10Env> (*)(const std::string& task, std::int64_t index, MT10Options options);

struct MT10Task {
  std::string name;  // "reach", ...; the task is "mt10/<name>"
  MT10Factory make;
  ScriptedExpert expert;
  // Success rate of the expert (mean action) over 100 episodes from evaluation seeds, horizon 150, measured by
  // `maps expert-eval --set mt10 --episodes 100` (docs/mt10.md).
  double documented_success = 0.0;
};

// reach, push, pick-place, door-open, drawer-open, drawer-close, button-press-topdown, peg-insert-side,
// window-open, window-close (the one-hot index is the position here).
const std::vector<MT10Task>& mt10_tasks();
// The entry of "mt10/<name>" or "<name>"; an unknown name is an error listing the valid ones.
const MT10Task& mt10_task(const std::string& name);

// Each task file defines its env and its expert.
std::unique_ptr<MT10Env> make_reach(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d reach_expert(const Eigen::VectorXd& obs);
std::unique_ptr<MT10Env> make_push(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d push_expert(const Eigen::VectorXd& obs);
std::unique_ptr<MT10Env> make_pick_place(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d pick_place_expert(const Eigen::VectorXd& obs);
std::unique_ptr<MT10Env> make_door_open(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d door_open_expert(const Eigen::VectorXd& obs);
std::unique_ptr<MT10Env> make_drawer_open(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d drawer_open_expert(const Eigen::VectorXd& obs);
std::unique_ptr<MT10Env> make_drawer_close(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d drawer_close_expert(const Eigen::VectorXd& obs);
std::unique_ptr<MT10Env> make_button_press_topdown(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d button_press_topdown_expert(const Eigen::VectorXd& obs);
std::unique_ptr<MT10Env> make_peg_insert_side(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d peg_insert_side_expert(const Eigen::VectorXd& obs);
std::unique_ptr<MT10Env> make_window_open(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d window_open_expert(const Eigen::VectorXd& obs);
std::unique_ptr<MT10Env> make_window_close(const std::string& task, std::int64_t index, MT10Options options);
Eigen::Vector4d window_close_expert(const Eigen::VectorXd& obs);

// Meta-World's move(): p * (to - from); the env clips the result to [-1, 1].
inline Eigen::Vector3d move_toward(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double p) {
  return p * (to - from);
}
// Observation parts the experts read.
inline Eigen::Vector3d obs_hand(const Eigen::VectorXd& obs) { return obs.segment<3>(0); }
inline double obs_gripper(const Eigen::VectorXd& obs) { return obs[3]; }
inline Eigen::Vector3d obs_object(const Eigen::VectorXd& obs) { return obs.segment<3>(4); }
inline Eigen::Vector3d obs_goal(const Eigen::VectorXd& obs) { return obs.segment<3>(36); }
inline Eigen::Vector4d expert_action(const Eigen::Vector3d& delta, double grab) {
  return Eigen::Vector4d(delta.x(), delta.y(), delta.z(), grab);
}

}  // namespace maps::envs::mt10
