#include "envs/task_expert.h"

#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "envs/mt10/tasks.h"
#include "envs/source_folders.h"
#include "envs/task_sets.h"
#include "io/json_input.h"

namespace maps::envs {

TaskExpert task_expert_from_policy(ExpertPolicy policy, std::string source) {
  policy.validate();
  auto shared = std::make_shared<const ExpertPolicy>(std::move(policy));
  TaskExpert expert;
  expert.task = shared->task;
  expert.source = std::move(source);
  expert.mean_action = [shared](const Eigen::VectorXd& obs) { return shared->mean_action(obs); };
  expert.sample_action = [shared](const Eigen::VectorXd& obs, std::mt19937_64& rng) {
    return shared->sample_action(obs, rng);
  };
  nlohmann::json metadata;
  try {
    metadata = io::parse_json(shared->metadata_json, "expert " + expert.task + "'s metadata");
  } catch (const std::runtime_error&) {
    // The loader checked the metadata already; a documented return is optional.
  }
  expert.documented_return =
      metadata.is_object() && metadata.contains("eval_return_mean") && metadata["eval_return_mean"].is_number()
          ? metadata["eval_return_mean"].get<double>()
          : std::nan("");
  return expert;
}

TaskExpert load_task_expert(const std::string& task, const std::filesystem::path& experts_dir) {
  std::function<TaskExpert()> from_its_set;
  try {
    from_its_set = registered_expert(task);
  } catch (const std::invalid_argument&) {
    // Not a task of any set: the expert file is looked for, and its absence named, below.
  }
  if (from_its_set) {
    TaskExpert expert = from_its_set();
    if (expert.task != task || !expert.mean_action || !expert.sample_action)
      throw std::runtime_error("the expert task set " + task_set_of(task) + " gives for " + task +
                               " is not one (its task is '" + expert.task +
                               "'; it needs mean_action and "
                               "sample_action)");
    return expert;
  }
  if (task.rfind("mt10/", 0) == 0) {
    const mt10::ScriptedExpert policy = mt10::mt10_task(task).expert;
    TaskExpert expert;
    expert.task = task;
    expert.source = "scripted";
    expert.mean_action = [policy](const Eigen::VectorXd& obs) -> Eigen::VectorXd { return policy(obs); };
    expert.sample_action = [policy](const Eigen::VectorXd& obs, std::mt19937_64& rng) -> Eigen::VectorXd {
      std::normal_distribution<double> noise(0.0, kScriptedNoiseStd);
      Eigen::VectorXd action = policy(obs);
      for (Eigen::Index i = 0; i < action.size(); ++i) action[i] += noise(rng);
      return action;
    };
    expert.documented_return = std::nan("");
    return expert;
  }
  const std::filesystem::path dir = experts_dir.empty() ? envs::experts_dir() : experts_dir;
  const std::filesystem::path path = dir / (task + ".json");
  if (!std::filesystem::is_regular_file(path))
    throw std::runtime_error("no expert for task '" + task + "': " + path.string() +
                             " does not exist (train one with `maps train-expert --task " + task + "`)");
  ExpertPolicy policy = ExpertPolicy::load(path.string());
  if (policy.task != task)
    throw std::runtime_error("expert file " + path.string() + " holds an expert of '" + policy.task + "', not '" +
                             task + "'");
  return task_expert_from_policy(std::move(policy), path.string());
}

}  // namespace maps::envs
