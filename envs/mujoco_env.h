#pragma once

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <random>
#include <string>

#include "envs/env.h"

// The MuJoCo base of every task: owns the compiled model and its data, checks and clips actions,
// skips frames, and keeps the episode bookkeeping (reset before stepping, the time limit, no step
// after done). A task implements reset_model() and step_clipped() only, like Gym's MujocoEnv.
namespace maps::envs {

struct MjModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct MjDataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using MjModelPtr = std::unique_ptr<mjModel, MjModelDeleter>;
using MjDataPtr = std::unique_ptr<mjData, MjDataDeleter>;

// Compiles MJCF text held in memory. `name` says what is being loaded (a task or a file) and
// appears in the error, which carries MuJoCo's own message.
MjModelPtr load_model_from_string(const std::string& xml, const std::string& name);
// Compiles an MJCF file; the error names the file.
MjModelPtr load_model_from_file(const std::filesystem::path& path);

// The folder holding the MJCF files: $MAPS_ASSETS_DIR if set (it must then exist), else
// envs/assets/ of the source tree this library was built from, else the first envs/assets/
// found walking up from the working directory. Throws, listing what was tried, if none exists.
std::filesystem::path assets_dir();
// assets_dir() / file_name, which must exist.
std::filesystem::path asset_path(const std::string& file_name);
// The whole file as text; throws naming the file if it cannot be read.
std::string read_text_file(const std::filesystem::path& path);

// Identifies the env code and the physics engine in data files: "maps-envs 1, MuJoCo <version>".
std::string mujoco_env_version();

class MujocoEnv : public Env {
 public:
  const EnvSpec& spec() const override { return spec_; }
  // mj_resetData, then the task's reset_model() with an RNG seeded by `seed`.
  Eigen::VectorXd reset(std::uint64_t seed) final;
  // Checks the action (size, NaN) and the episode state, clips to the bounds, runs the task's
  // step_clipped(), then sets `truncated` once the horizon is reached.
  StepResult step(const Eigen::VectorXd& action) final;

  const mjModel* model() const { return model_.get(); }
  const mjData* data() const { return data_.get(); }
  int frame_skip() const { return frame_skip_; }
  double dt() const { return model_->opt.timestep * frame_skip_; }  // seconds per env step
  int elapsed_steps() const { return elapsed_steps_; }
  // Sets qpos (size nq) and qvel (size nv), then mj_forward; the episode bookkeeping is unchanged.
  void set_state(const Eigen::VectorXd& qpos, const Eigen::VectorXd& qvel);

 protected:
  // `spec.action_low/high` must have spec.action_size entries.
  MujocoEnv(EnvSpec spec, MjModelPtr model, int frame_skip);

  mjModel* mutable_model() { return model_.get(); }
  mjData* mutable_data() { return data_.get(); }

  // After mj_resetData: sets the initial state (drawing from `rng`) and returns the observation.
  virtual Eigen::VectorXd reset_model(std::mt19937_64& rng) = 0;
  // One env step with an action already checked and clipped to the bounds. `terminated`,
  // `truncated` are left for the base to complete (it ORs in the time limit).
  virtual StepResult step_clipped(const Eigen::VectorXd& action) = 0;
  // The weight of a squared-norm control cost in the reward (0: none), for StepResult::unclipped_control_cost.
  virtual double control_cost_weight() const { return 0.0; }

  // Copies `ctrl` (size nu) into data->ctrl and calls mj_step frame_skip times.
  void do_simulation(const Eigen::VectorXd& ctrl);

 private:
  // Throws when the last step overflowed the model's contact or constraint capacity.
  void check_capacity() const;
  EnvSpec spec_;
  MjModelPtr model_;
  MjDataPtr data_;
  int frame_skip_;
  int elapsed_steps_ = 0;
  bool needs_reset_ = true;  // true before the first reset() and after an episode ended
  Eigen::VectorXd clipped_;  // scratch for the clipped action (no allocation per step)
};

}  // namespace maps::envs
