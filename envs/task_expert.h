#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <random>
#include <string>

#include "envs/expert_policy.h"

// The expert of any task, behind one face: HalfCheetah's trained MLP policies (envs/experts/<set>/<task>.json)
// and MT10's scripted policies. Demonstration collection, rendering and expert evaluation use it.
namespace maps::envs {

struct TaskExpert {
  std::string task;
  std::string source;  // where it came from: the JSON file, or "scripted"
  std::function<Eigen::VectorXd(const Eigen::VectorXd& obs)> mean_action;
  // mean_action plus the expert's own exploration noise
  std::function<Eigen::VectorXd(const Eigen::VectorXd& obs, std::mt19937_64& rng)> sample_action;
  // The score the expert's documentation records (HalfCheetah: the mean evaluation return; MT10: NaN, scored by
  // success instead).
  double documented_return = 0.0;
};

// Wraps a trained MLP expert (its task, its metadata's eval_return_mean).
TaskExpert task_expert_from_policy(ExpertPolicy policy, std::string source = "");

// Standard deviation of the Gaussian noise a scripted MT10 expert's sample_action adds to each action entry (10% of
// the [-1, 1] range, as Meta-World's noisy policy tests).
inline constexpr double kScriptedNoiseStd = 0.2;

// The expert of `task`: an MT10 task's scripted policy, else the committed MLP expert
// `experts_dir`/<task>.json (empty: envs::experts_dir()). A missing file is an error naming it.
TaskExpert load_task_expert(const std::string& task, const std::filesystem::path& experts_dir = {});

}  // namespace maps::envs
