#include "maps/data/demo_dataset.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "envs/portable_random.h"

namespace maps::core {
namespace {

using envs::draw_below;
using envs::splitmix64;

// FNV-1a: a task name's stream, the same on every platform and build.
std::uint64_t name_hash(const std::string& name) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : name) h = (h ^ c) * 0x100000001b3ULL;
  return h;
}

// Rows of a demo kept for training or validation, with each row's predecessor in time (row t - 1 of the demo,
// row 0 paired with itself). The predecessor is the real previous state even when subsampling skips it: the
// smoothness loss compares consecutive states, and it reads only observations, never action labels.
// With horizon H > 1 a row's actions are the chunk of the H actions from its own on, the last repeated past the end.
void append_rows(const envs::Demonstration& demo, std::int64_t offset, std::int64_t step, std::int64_t horizon,
                 Eigen::MatrixXd& obs, Eigen::MatrixXd& prev, Eigen::MatrixXd& actions) {
  const std::int64_t T = demo.num_samples();
  const std::int64_t kept = offset < T ? (T - offset + step - 1) / step : 0;
  const Eigen::Index start = obs.rows();
  const Eigen::Index A = demo.actions.cols();
  obs.conservativeResize(start + kept, demo.obs.cols());
  prev.conservativeResize(start + kept, demo.obs.cols());
  actions.conservativeResize(start + kept, horizon * A);
  for (std::int64_t i = 0; i < kept; ++i) {
    const std::int64_t t = offset + i * step;
    obs.row(start + i) = demo.obs.row(t);
    prev.row(start + i) = demo.obs.row(t > 0 ? t - 1 : 0);
    for (std::int64_t j = 0; j < horizon; ++j)
      actions.block(start + i, j * A, 1, A) = demo.actions.row(std::min(t + j, T - 1));
  }
}

// The position of task `name` in the file's tasks; `key` names the config key that asked for it.
// The position of `name` among `tasks`; an error naming the config key, what the tasks are of, and the tasks.
int find_task(const std::vector<std::string>& tasks, const std::string& name, const std::string& key,
              const std::string& tasks_of) {
  const auto found = std::find(tasks.begin(), tasks.end(), name);
  if (found == tasks.end()) {
    std::string known;
    for (const auto& task : tasks) known += (known.empty() ? "" : ", ") + task;
    throw std::invalid_argument(key + ": '" + name + "' is not a task of " + tasks_of + " (" + known + ")");
  }
  return static_cast<int>(found - tasks.begin());
}

int task_index(const std::vector<std::string>& file_tasks, const std::string& task_set, const std::string& name,
               const std::string& key) {
  return find_task(file_tasks, name, "data." + key, "the demo file's set " + task_set);
}

}  // namespace

void check_draws(const std::string& draws) {
  if (draws != "sequential" && draws != "per_task")
    throw std::invalid_argument("data.draws: expected \"sequential\" or \"per_task\", got \"" + draws + "\"");
}

std::vector<bool> kept_tasks(const std::vector<std::string>& file_tasks, const std::string& task_set,
                             const DataConfig& config) {
  std::vector<bool> keep(file_tasks.size(), config.tasks.empty());
  for (const auto& name : config.tasks) keep[task_index(file_tasks, task_set, name, "tasks")] = true;
  for (const auto& name : config.holdout) keep[task_index(file_tasks, task_set, name, "holdout")] = false;
  return keep;
}

DemoDataset::DemoDataset(const envs::DemoFile& file, const DataConfig& config)
    : task_set_(file.task_set), config_(config) {
  if (config.action_horizon < 1 || config.action_horizon > 1000)
    throw std::invalid_argument("data: action horizon must be 1 to 1000, got " + std::to_string(config.action_horizon));
  if (!std::isfinite(config.observation_clip) || config.observation_clip < 0.0)
    throw std::invalid_argument("data: observation_clip must be finite and >= 0 (0: no clamp), got " +
                                std::to_string(config.observation_clip));
  if (config.subsample < 1)
    throw std::invalid_argument("data: subsample must be >= 1, got " + std::to_string(config.subsample));
  if (config.demos_per_task < 0)
    throw std::invalid_argument("data: demos_per_task must be >= 0, got " + std::to_string(config.demos_per_task));
  if (file.demos.empty()) throw std::invalid_argument("data: the demo file holds no demonstrations");
  action_size_ = file.demos.front().actions.cols();
  const int file_tasks = static_cast<int>(file.task_names.size());
  const std::vector<bool> keep = kept_tasks(file.task_names, file.task_set, config);
  std::vector<int> demos_of(static_cast<std::size_t>(file_tasks), config.demos_per_task);
  for (const auto& [name, count] : config.task_demos) {
    if (count < 0)
      throw std::invalid_argument("data.task_demos." + name + ": must be >= 0, got " + std::to_string(count));
    demos_of[task_index(file.task_names, file.task_set, name, "task_demos")] = count;
  }
  if (std::find(keep.begin(), keep.end(), true) == keep.end())
    throw std::invalid_argument("data: data.tasks and data.holdout leave no task to train on");

  std::vector<std::vector<int>> train(file_tasks), valid(file_tasks);
  for (int i : file.train) train[file.demos[i].task_index].push_back(i);
  for (int i : file.valid) valid[file.demos[i].task_index].push_back(i);

  // Every task of the file is drawn, kept or not, in the file's order: a task's draw depends only on the seed and
  // the counts, not on which other tasks a run keeps.
  check_draws(config.draws);
  const std::uint64_t data_stream = splitmix64(config.seed ^ 0x6d6170732d646174ULL);  // a stream of its own: "maps-dat"
  std::mt19937_64 rng(data_stream);
  Eigen::MatrixXd all_train_obs(0, file.demos.front().obs.cols());
  for (int k = 0; k < file_tasks; ++k) {
    const bool kept = keep[k];
    std::vector<int>& pool = train[k];
    auto wanted = demos_of[k] == 0 ? pool.size() : static_cast<std::size_t>(demos_of[k]);
    if (config.draws == "per_task") rng.seed(splitmix64(data_stream ^ name_hash(file.task_names[k])));
    if (kept && (pool.size() < wanted || pool.empty()))
      throw std::invalid_argument("data: task " + file.task_names[k] + " has " + std::to_string(pool.size()) +
                                  " training demos (mask/train), " + std::to_string(wanted) + " requested");
    if (kept && valid[k].empty())
      throw std::invalid_argument("data: task " + file.task_names[k] + " has no validation demos");
    wanted = std::min(wanted, pool.size());
    for (std::size_t i = pool.size(); i > 1; --i) std::swap(pool[i - 1], pool[draw_below(rng, i)]);
    pool.resize(wanted);
    std::sort(pool.begin(), pool.end());
    TaskData data;
    std::vector<std::uint64_t> seeds;
    for (int i : pool) {
      const std::int64_t offset = static_cast<std::int64_t>(draw_below(rng, config.subsample));
      append_rows(file.demos[i], offset, config.subsample, config.action_horizon, data.train_obs, data.train_prev_obs,
                  data.train_actions);
      seeds.push_back(file.demos[i].seed);
    }
    if (!kept) continue;
    if (data.train_obs.rows() == 0)
      throw std::invalid_argument("data: subsample " + std::to_string(config.subsample) + " leaves task " +
                                  file.task_names[k] + " no training states");
    for (int i : valid[k])
      append_rows(file.demos[i], 0, 1, config.action_horizon, data.valid_obs, data.valid_prev_obs, data.valid_actions);
    double total = 0.0;
    int count = 0;
    for (const auto& demo : file.demos)
      if (demo.task_index == k) total += demo.episode_return, ++count;
    data.demo_mean_return = total / count;
    const Eigen::Index rows = all_train_obs.rows();
    all_train_obs.conservativeResize(rows + data.train_obs.rows(), Eigen::NoChange);
    all_train_obs.bottomRows(data.train_obs.rows()) = data.train_obs;
    task_names_.push_back(file.task_names[k]);
    tasks_.push_back(std::move(data));
    training_seeds_.push_back(std::move(seeds));
  }
  standardizer_ = Standardizer::fit(all_train_obs);
  standardizer_.clip = config.observation_clip;
}

void DemoDataset::use_standardizer(const Standardizer& standardizer) {
  if (standardizer.mean.size() != standardizer_.size() || standardizer.std.size() != standardizer_.size())
    throw std::invalid_argument("data: a standardizer of " + std::to_string(standardizer.mean.size()) +
                                " dimensions for observations of " + std::to_string(standardizer_.size()));
  standardizer_ = standardizer;
  standardizer_.clip = config_.observation_clip;
}

Batch DemoDataset::make_batch(const std::vector<std::pair<int, std::int64_t>>& picks, ag::Dtype dtype, bool validation,
                              std::int64_t per_task) const {
  const auto n = static_cast<Eigen::Index>(picks.size());
  Eigen::MatrixXd obs(n, observation_size()), prev(n, observation_size()),
      actions(n, action_size_ * config_.action_horizon);
  Batch batch;
  batch.tasks.reserve(picks.size());
  for (Eigen::Index j = 0; j < n; ++j) {
    const auto [task, row] = picks[static_cast<std::size_t>(j)];
    const TaskData& data = tasks_[task];
    obs.row(j) = (validation ? data.valid_obs : data.train_obs).row(row);
    prev.row(j) = (validation ? data.valid_prev_obs : data.train_prev_obs).row(row);
    actions.row(j) = (validation ? data.valid_actions : data.train_actions).row(row);
    batch.tasks.push_back(task);
  }
  batch.observations = standardizer_.apply(obs, dtype);
  batch.previous_observations = standardizer_.apply(prev, dtype);
  batch.actions = ag::from_eigen(actions).to(dtype);
  batch.per_task = per_task;
  return batch;
}

Batch DemoDataset::sample(std::int64_t per_task, std::mt19937_64& rng, ag::Dtype dtype) const {
  if (per_task < 1) throw std::invalid_argument("data: states per task must be >= 1");
  std::vector<std::pair<int, std::int64_t>> picks;
  picks.reserve(static_cast<std::size_t>(per_task * num_tasks()));
  for (int k = 0; k < num_tasks(); ++k)
    for (std::int64_t i = 0; i < per_task; ++i)
      picks.emplace_back(k, static_cast<std::int64_t>(draw_below(rng, tasks_[k].train_obs.rows())));
  return make_batch(picks, dtype, false, per_task);
}

Batch DemoDataset::task_training_batch(int task, std::int64_t n, std::mt19937_64& rng, ag::Dtype dtype) const {
  if (task < 0 || task >= num_tasks())
    throw std::invalid_argument("data: task index " + std::to_string(task) + " out of range");
  std::vector<std::pair<int, std::int64_t>> picks;
  for (std::int64_t i = 0; i < n; ++i)
    picks.emplace_back(task, static_cast<std::int64_t>(draw_below(rng, tasks_[task].train_obs.rows())));
  return make_batch(picks, dtype, false, 0);
}

Batch DemoDataset::task_validation_batch(int task, ag::Dtype dtype) const {
  if (task < 0 || task >= num_tasks())
    throw std::invalid_argument("data: task index " + std::to_string(task) + " out of range");
  std::vector<std::pair<int, std::int64_t>> picks;
  for (std::int64_t r = 0; r < tasks_[task].valid_obs.rows(); ++r) picks.emplace_back(task, r);
  return make_batch(picks, dtype, true, 0);
}

Batch DemoDataset::validation_batch(ag::Dtype dtype, std::int64_t max_per_task,
                                    const std::vector<std::string>& tasks) const {
  std::vector<bool> chosen(static_cast<std::size_t>(num_tasks()), tasks.empty());
  for (const auto& name : tasks)
    chosen[static_cast<std::size_t>(find_task(task_names_, name, "train.validation_tasks", "this run"))] = true;
  std::vector<std::pair<int, std::int64_t>> picks;
  for (int k = 0; k < num_tasks(); ++k) {
    if (!chosen[static_cast<std::size_t>(k)]) continue;
    const std::int64_t rows = tasks_[k].valid_obs.rows();
    const std::int64_t count = max_per_task > 0 ? std::min(rows, max_per_task) : rows;
    for (std::int64_t i = 0; i < count; ++i) picks.emplace_back(k, i * rows / count);
  }
  return make_batch(picks, dtype, true, 0);
}

}  // namespace maps::core
