#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <utility>

// The interface every task implements. Policies reach an env as plain Eigen vectors; envs/
// knows nothing of autograd.
namespace maps::envs {

struct EnvSpec {
  std::string task;             // stable name, e.g. "gravity/0.5" or "modified/big_foot"
  std::int64_t task_index = 0;  // index within its task set (the one-hot task id)
  int observation_size = 0;
  int action_size = 0;
  Eigen::VectorXd action_low;  // per-dimension bounds; actions outside are clipped
  Eigen::VectorXd action_high;
  int horizon = 0;  // steps per episode (the time limit)
};

// A spec whose every action entry is bounded by [-1, 1] (HalfCheetah, MT10).
inline EnvSpec unit_box_spec(std::string task, std::int64_t task_index, int observation_size, int action_size,
                             int horizon) {
  EnvSpec spec;
  spec.task = std::move(task);
  spec.task_index = task_index;
  spec.observation_size = observation_size;
  spec.action_size = action_size;
  spec.action_low = Eigen::VectorXd::Constant(action_size, -1.0);
  spec.action_high = Eigen::VectorXd::Constant(action_size, 1.0);
  spec.horizon = horizon;
  return spec;
}

struct StepResult {
  Eigen::VectorXd observation;
  double reward = 0.0;
  bool terminated = false;  // the task itself ended the episode (a real terminal state)
  bool truncated = false;   // the time limit was reached: bootstrap from `observation`
  bool success = false;     // the task's success test holds at this step
  // What Gym's HalfCheetah (v2-v4) would charge beyond `reward`'s cost: its control cost is on the action as
  // given, ours on the action clipped to the bounds (DESIGN.md). 0 inside the bounds and for tasks without one.
  double unclipped_control_cost = 0.0;
  bool done() const { return terminated || truncated; }
};

class Env {
 public:
  virtual ~Env() = default;
  virtual const EnvSpec& spec() const = 0;
  // Starts an episode from the initial state drawn with `seed`; the same seed gives the same
  // initial state and, with the same actions, the same trajectory.
  virtual Eigen::VectorXd reset(std::uint64_t seed) = 0;
  // An action of the wrong size or with a NaN is an error naming the task; values outside the
  // bounds are clipped. Stepping before reset() or after done() is an error.
  virtual StepResult step(const Eigen::VectorXd& action) = 0;
  // True when the body is in a state the task treats as failed whatever the reward says (HalfCheetah: turned
  // over). Demonstration collection discards episodes that end in, or spend long in, such a state.
  virtual bool in_failure_state() const { return false; }
};

}  // namespace maps::envs
