#pragma once

#include <string>

namespace maps::experiments {

// `maps bench eval --set gravity|modified|mt10 [--method NAME]`: evaluates a policy of the method at its defaults
// (MAPS: the paper's shape; fresh weights: the cost of a rollout does not depend on them, every episode of these sets
// runs to its horizon unless an MT10 task succeeds) with the evaluator's defaults, and prints where the time goes:
// building and resetting envs, stepping them, and the policy (standardising, act, and the selector scores for module
// usage).
struct BenchEvalOptions {
  std::string set = "gravity";
  std::string method = "maps";  // any registered method at its defaults (its module usage too where it routes)
  std::string config_path;      // a partial run config over them, as `maps bench step --config`
  int episodes = 10;            // per task
  int threads = 1;              // evaluator threads (tasks side by side); ops stay on one thread each
  int max_envs = 10;            // envs alive per task (the evaluator's default)
  bool json = false;
};

int run_bench_eval(const BenchEvalOptions& options);

}  // namespace maps::experiments
