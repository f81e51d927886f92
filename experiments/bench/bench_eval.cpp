#include "experiments/bench/bench_eval.h"

#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "envs/task_sets.h"
#include "experiments/bench/bench_request.h"
#include "experiments/process/cpu_model.h"
#include "experiments/run/run_folder.h"
#include "maps/evaluation/evaluator.h"
#include "maps/policies/maps_policy.h"
#include "maps/training/run_config.h"

namespace maps::experiments {

int run_bench_eval(const BenchEvalOptions& options) {
  if (options.episodes < 1) throw std::invalid_argument("bench eval: --episodes must be >= 1");
  if (options.threads < 1) throw std::invalid_argument("bench eval: --threads must be >= 1");
  if (options.max_envs < 1) throw std::invalid_argument("bench eval: --max-envs must be >= 1");
  const std::vector<std::string> tasks = envs::task_names(options.set);  // throws naming the known sets
  const auto probe = envs::make_env(tasks.front());
  const envs::EnvSpec& spec = probe->spec();
  const core::RunConfig run_config =
      parse_run_config_from(bench_request(options.method, options.config_path, "bench eval"), "bench eval");
  const auto policy_pointer =
      core::make_policy(run_config, {spec.observation_size, spec.action_size, static_cast<std::int64_t>(tasks.size())});
  core::Policy& policy = *policy_pointer;
  policy.eval();
  core::Standardizer standardizer;
  standardizer.mean = Eigen::VectorXd::Zero(spec.observation_size);
  standardizer.std = Eigen::VectorXd::Ones(spec.observation_size);
  // Module usage as `maps eval` records it, for a method that routes (MAPS's selector scores, the zoo's shares).
  const core::ModuleUsageFn usage = [&policy](const ag::Tensor& obs, const std::vector<std::int64_t>& ids) {
    return policy.routing(obs, ids);
  };
  core::EvalConfig config;
  config.episodes = options.episodes;
  config.threads = options.threads;
  config.max_envs_per_task = options.max_envs;
  const core::EvaluationResult r =
      core::evaluate(policy, standardizer, tasks, {}, config, policy.routed_modules() > 0 ? &usage : nullptr);

  // Every episode of a fresh policy runs to the horizon unless an MT10 task happens to succeed (it rarely does);
  // the per-step costs below assume the full horizon.
  const double env_steps = static_cast<double>(tasks.size()) * options.episodes * spec.horizon;
  const double busy = r.setup_seconds + r.env_seconds + r.policy_seconds;
  const nlohmann::json result{{"set", options.set},
                              {"method", options.method},
                              {"cpu", cpu_model()},
                              {"tasks", tasks.size()},
                              {"episodes_per_task", options.episodes},
                              {"horizon", spec.horizon},
                              {"threads", options.threads},
                              {"max_envs_per_task", options.max_envs},
                              {"wall_seconds", r.seconds},
                              {"setup_seconds", r.setup_seconds},
                              {"env_seconds", r.env_seconds},
                              {"policy_seconds", r.policy_seconds},
                              {"env_us_per_step", r.env_seconds / env_steps * 1e6},
                              {"policy_us_per_row", r.policy_seconds / env_steps * 1e6},
                              {"policy_us_per_call", r.policy_seconds / (env_steps / options.max_envs) * 1e6}};
  if (options.json) {
    std::cout << result.dump() << std::endl;
    return 0;
  }
  std::printf("%s evaluation, set %s: %zu tasks x %d episodes x %d steps, %d evaluator thread(s), %d envs per task\n",
              options.method.c_str(), options.set.c_str(), tasks.size(), options.episodes, spec.horizon,
              options.threads, options.max_envs);
  std::printf("  CPU: %s\n", cpu_model().c_str());
  std::printf("  wall %.2f s; summed over tasks: env creation and resets %.2f s (%.0f%%), env steps %.2f s (%.0f%%),\n",
              r.seconds, r.setup_seconds, 100.0 * r.setup_seconds / busy, r.env_seconds, 100.0 * r.env_seconds / busy);
  std::printf("  standardise + act (+ routing) %.2f s (%.0f%%)\n", r.policy_seconds, 100.0 * r.policy_seconds / busy);
  std::printf("  per env step: %.1f us stepping, %.1f us of policy per row (%.0f us per batched call of %d rows)\n",
              result["env_us_per_step"].get<double>(), result["policy_us_per_row"].get<double>(),
              result["policy_us_per_call"].get<double>(), options.max_envs);
  return 0;
}

}  // namespace maps::experiments
