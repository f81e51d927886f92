#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "envs/mt10/mt10_env.h"

// The ten MT10 tasks in Meta-World's order, each with its scripted expert: a pure function of the observation
// following Meta-World's policy for the task (../shared/reference/mt10.md section 3). One file per task
// (envs/mt10/reach.cpp, ...), which registers its entry with an MT10TaskRegistration.
namespace maps::envs::mt10 {

using ScriptedExpert = Eigen::Vector4d (*)(const Eigen::VectorXd& observation);
using MT10Factory = std::unique_ptr<MT10Env> (*)(const std::string& task, std::int64_t index, MT10Options options);

struct MT10Task {
  std::string name;  // "reach", ...; the task is "mt10/<name>"
  // Its position in Meta-World's order (mt10_tasks()), which is its one-hot task index.
  std::int64_t index = -1;
  MT10Factory make = nullptr;
  ScriptedExpert expert = nullptr;
  // Success rate of the expert (mean action) over 100 episodes from evaluation seeds, horizon 150, measured by
  // `maps expert-eval --set mt10 --episodes 100` (docs/mt10.md).
  double documented_success = 0.0;
};

constexpr std::int64_t kMT10TaskCount = 10;

// A task file's entry, added to the registry while the program starts (static initialisation):
//   const MT10TaskRegistration reach_registration({"reach", 0, make_reach, reach_expert, 1.0});
// The task files are linked into every program that links maps_envs (envs/CMakeLists.txt), so that none is dropped.
class MT10TaskRegistration {
 public:
  explicit MT10TaskRegistration(MT10Task task);
};

// The registered tasks sorted by index: reach, push, pick-place, door-open, drawer-open, drawer-close,
// button-press-topdown, peg-insert-side, window-open, window-close. Checked once: indices exactly 0 to 9, names
// distinct; otherwise std::logic_error, and the next call checks again. From a static initialiser it sees the tasks
// whose registrations have run: all of them in the libraries' initialisers (the task objects come before every
// library on the link line), not yet in those of a program's own source files, which run first.
const std::vector<MT10Task>& mt10_tasks();
// The entry of "mt10/<name>" or "<name>"; an unknown name is an error listing the valid ones.
const MT10Task& mt10_task(const std::string& name);
// mt10_tasks()'s ordering and check, for any list of entries: sorted by index; std::logic_error naming the tasks
// unless the indices are exactly 0 .. count-1 and the names distinct.
std::vector<MT10Task> ordered_mt10_tasks(std::vector<MT10Task> tasks, std::int64_t count = kMT10TaskCount);

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
