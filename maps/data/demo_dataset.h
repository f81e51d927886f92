#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "autograd/autograd.h"
#include "envs/demo_file.h"
#include "maps/data/batch.h"
#include "maps/data/standardizer.h"

// The demonstrations a run trains on, drawn from a demo file by the run's seed, and the batches the trainer
// draws from them.
namespace maps::core {

struct DataConfig {
  // Training demonstrations per task, drawn without replacement from the task's mask/train demos; 0 takes all.
  int demos_per_task = 0;
  // Keep every k-th state-action pair of each demo, from an offset drawn in [0, k) (GAIL's protocol); 1 keeps all.
  int subsample = 1;
  // Draws the demos and offsets. Every method given the same seed sees the same data (paired comparisons).
  std::uint64_t seed = 0;
  // Only these tasks of the file (empty: all); the dataset's task ids follow the set's order among the kept tasks.
  std::vector<std::string> tasks;
  // These tasks of the file are left out (a leave-one-out run that transfer then teaches them to).
  std::vector<std::string> holdout;
  // Training demonstrations of particular tasks, in place of demos_per_task for them (a new task's few demos).
  std::vector<std::pair<std::string, int>> task_demos;
  // How the demos and offsets are drawn. "sequential": one stream through the file's tasks in order, so a task's
  // draw also depends on the counts of the tasks before it (every run made before the option). "per_task": each
  // task a stream of its own from the seed and its name, so its draw depends on the seed and its own count only
  // (transfer's comparison: the other tasks get the same demos whatever the new task's count).
  std::string draws = "sequential";
  // H: a batch's actions are chunks [n, H * A], each row the state's action and the H - 1 after it in its
  // demonstration, time-major, the last action repeated past the demonstration's end (Diffusion Policy's padding);
  // 1: [n, A]. Set from the method's chunking, not by a config key of its own.
  std::int64_t action_horizon = 1;
  // > 0: standardised observations are clamped to [-clip, clip] wherever the run standardises (batches, validation,
  // rollouts, evaluation; Standardizer::clip); 0: not clamped.
  double observation_clip = 0.0;
};

// data.draws must be "sequential" or "per_task": an error naming it otherwise.
void check_draws(const std::string& draws);

// Which of a demo file's tasks (in the file's order) a run of `config` trains on: data.tasks (all when empty) less
// data.holdout. Throws std::invalid_argument naming a task the file's set lacks.
std::vector<bool> kept_tasks(const std::vector<std::string>& file_tasks, const std::string& task_set,
                             const DataConfig& config);

class DemoDataset {
 public:
  // Throws std::invalid_argument naming what is wrong: a task with fewer training demos than asked for, a
  // subsample factor < 1, a demo shorter than the factor leaves nothing of, a task name not in the file, no task
  // left. The demos of every task of the file are drawn in the file's order whatever is kept, so a task's draw is
  // the same in a run of all tasks, a leave-one-out run and a run of that task alone (same seed and counts; with
  // draws "per_task", same seed and own count).
  DemoDataset(const envs::DemoFile& file, const DataConfig& config);

  int num_tasks() const { return static_cast<int>(task_names_.size()); }
  std::int64_t observation_size() const { return standardizer_.size(); }
  std::int64_t action_size() const { return action_size_; }  // A, one step's
  std::int64_t action_horizon() const { return config_.action_horizon; }
  const std::vector<std::string>& task_names() const { return task_names_; }
  const std::string& task_set() const { return task_set_; }
  const DataConfig& config() const { return config_; }
  // Fitted to the kept training states of all tasks, unless replaced.
  const Standardizer& standardizer() const { return standardizer_; }
  // Standardise with these statistics instead (transfer: the ones the reused modules were trained with), clamped
  // as this run's config says (data.observation_clip, not the standardizer's own). A size other than the
  // observations' is an error.
  void use_standardizer(const Standardizer& standardizer);
  // The reset seeds of the demos drawn for training, per task (what a run used, for its record).
  const std::vector<std::vector<std::uint64_t>>& training_demo_seeds() const { return training_seeds_; }
  std::int64_t training_samples(int task) const { return tasks_.at(task).train_obs.rows(); }
  std::int64_t validation_samples(int task) const { return tasks_.at(task).valid_obs.rows(); }
  // Mean return of the task's demonstrations in the file (train and valid): the HalfCheetah score's normaliser.
  double demo_mean_return(int task) const { return tasks_.at(task).demo_mean_return; }

  // A balanced batch: `per_task` training states of every task, drawn uniformly with replacement, task 0's first.
  Batch sample(std::int64_t per_task, std::mt19937_64& rng, ag::Dtype dtype) const;
  // `n` training states of one task (drawn with replacement), tasks all equal to `task`.
  Batch task_training_batch(int task, std::int64_t n, std::mt19937_64& rng, ag::Dtype dtype) const;
  // Every state of the task's validation demos (all of them, every state: subsampling is for training only).
  Batch task_validation_batch(int task, ag::Dtype dtype) const;
  // All tasks' validation states, task-major (per_task = 0: tasks may differ in count). With max_per_task > 0, at
  // most that many states per task, evenly spaced through the task's validation states (a fixed subset). With
  // `tasks` (names), only those tasks' states; a name the dataset lacks is an error.
  Batch validation_batch(ag::Dtype dtype, std::int64_t max_per_task = 0,
                         const std::vector<std::string>& tasks = {}) const;

 private:
  struct TaskData {
    Eigen::MatrixXd train_obs, train_prev_obs, train_actions;  // raw (not standardised)
    Eigen::MatrixXd valid_obs, valid_prev_obs, valid_actions;
    double demo_mean_return = 0.0;
  };
  Batch make_batch(const std::vector<std::pair<int, std::int64_t>>& picks, ag::Dtype dtype, bool validation,
                   std::int64_t per_task) const;

  std::string task_set_;
  std::vector<std::string> task_names_;
  DataConfig config_;
  std::int64_t action_size_ = 0;
  std::vector<TaskData> tasks_;
  std::vector<std::vector<std::uint64_t>> training_seeds_;
  Standardizer standardizer_;
};

}  // namespace maps::core
