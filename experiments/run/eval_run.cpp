// `maps eval`: the score of a trained run.

#include "experiments/run/eval_run.h"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>

#include "envs/task_sets.h"
#include "experiments/process/host.h"
#include "experiments/run/run_folder.h"
#include "io/output_files.h"
#include "maps/evaluation/evaluator.h"
#include "maps/policies/maps_policy.h"
#include "nn/serialize.h"

namespace maps::experiments {

namespace {

// One line per finished task, so a long evaluation is not silent: "[3/10] mt10/reach: score 0.90 (12 s)".
core::EvalProgressFn progress_lines(const std::vector<std::string>& tasks) {
  const auto start = std::chrono::steady_clock::now();
  auto finished = std::make_shared<std::size_t>(0);
  return [start, finished, count = tasks.size()](std::size_t, const core::TaskEvaluation& evaluation) {
    const double seconds = seconds_since(start);
    std::printf("  [%zu/%zu] %s: score %.3f, %d episodes (%.0f s)\n", ++*finished, count, evaluation.task.c_str(),
                evaluation.score, evaluation.episodes, seconds);
    std::fflush(stdout);
  };
}

// What evaluate() asks a policy that routes (its selector's scores per state); empty for one that does not.
core::ModuleUsageFn routing_of(core::Policy& policy) {
  if (policy.routed_modules() == 0) return {};
  return
      [&policy](const ag::Tensor& obs, const std::vector<std::int64_t>& tasks) { return policy.routing(obs, tasks); };
}

// A task's routing (module usage, selector entropy and top score) into its JSON entry, where its policy routes.
void add_routing(nlohmann::json& entry, const core::TaskEvaluation& t) {
  if (t.module_usage.size() == 0) return;
  entry["module_usage"] = std::vector<double>(t.module_usage.data(), t.module_usage.data() + t.module_usage.size());
  entry["selector_entropy"] = t.selector_entropy;
  entry["selector_top_score"] = t.selector_top_score;
}

std::vector<double> task_scores(const core::EvaluationResult& result) {
  std::vector<double> scores;
  for (const auto& t : result.tasks) scores.push_back(t.score);
  return scores;
}

nlohmann::json score_lists(const core::EvaluationResult& result) {
  std::vector<double> success, success_at_end;
  for (const auto& t : result.tasks) {
    success.push_back(t.success_rate);
    success_at_end.push_back(t.final_success_rate);
  }
  return {{"mean_score", result.mean_score},
          {"scores", task_scores(result)},
          {"success_rate", success},
          {"final_success_rate", success_at_end}};
}

int evaluate_each_module(const std::string& run, core::MAPSPolicy& policy, const core::DemoDataset& data,
                         const std::vector<std::string>& names, const std::vector<double>& expert_returns,
                         const core::EvalConfig& eval, const nlohmann::json& best) {
  std::printf("maps eval --each-module: %s, %d episodes per task, %lld modules\n", run.c_str(), eval.episodes,
              static_cast<long long>(policy.num_modules()));
  std::printf("| policy |");
  for (const auto& name : names) std::printf(" %s |", name.c_str());
  std::printf(" mean |\n|---|");
  for (std::size_t k = 0; k <= names.size(); ++k) std::printf("---|");
  std::printf("\n");
  auto print_row = [&](const std::string& label, const core::EvaluationResult& r) {
    std::printf("| %s |", label.c_str());
    for (const auto& t : r.tasks) std::printf(" %.2f |", t.score);
    std::printf(" %.3f |\n", r.mean_score);
    std::fflush(stdout);
  };
  policy.force_module(-1);
  const core::EvaluationResult full = core::evaluate(policy, data.standardizer(), names, expert_returns, eval);
  print_row("selector", full);
  nlohmann::json modules = nlohmann::json::array();
  for (std::int64_t j = 0; j < policy.num_modules(); ++j) {
    policy.force_module(j);
    const core::EvaluationResult r = core::evaluate(policy, data.standardizer(), names, expert_returns, eval);
    print_row("module " + std::to_string(j), r);
    nlohmann::json entry = score_lists(r);
    entry["module"] = j;
    modules.push_back(entry);
  }
  policy.force_module(-1);
  const nlohmann::json record{{"format", "maps-eval-modules/1"},
                              {"best_step", best.at("step")},
                              {"episodes", eval.episodes},
                              {"first_seed", eval.first_seed},
                              {"tasks", names},
                              {"selector", score_lists(full)},
                              {"modules", modules}};
  write_json_file((std::filesystem::path(run) / run_files::kEvalModules).string(), record);
  return 0;
}

}  // namespace

int run_eval(const EvalRunOptions& options) {
  namespace fs = std::filesystem;
  const fs::path dir(options.run);
  // Which checkpoints to score besides best.ckpt, found before any work is done.
  std::vector<std::pair<long long, std::string>> kept;
  if (options.checkpoints) {
    for (const auto& entry : fs::directory_iterator(dir)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("step_", 0) == 0 && name.size() > 10 && name.ends_with(".ckpt") &&
          name.find_first_not_of("0123456789", 5) == name.size() - 5)
        if (long long step = 0; std::from_chars(name.data() + 5, name.data() + name.size() - 5, step).ec == std::errc())
          kept.emplace_back(step, name);  // a number past long long's range is no kept step of this tool
    }
    std::sort(kept.begin(), kept.end());
    if (kept.empty())
      throw std::runtime_error(options.run + " kept no step_<N>.ckpt (train it with train.keep_every > 0)");
  }
  // A missing folder is load_trained_run's to name; an existing one must take the results before any work.
  if (fs::is_directory(dir))
    io::check_output_files_in("--run", options.run, {run_files::kEval, run_files::kEvalModules});
  TrainedRun run = load_trained_run(options.run);
  // last.ckpt is read and checked before any evaluation, so that a wrong one costs nothing.
  std::optional<FinalPolicy> final_policy;
  if (options.last) final_policy = load_final_policy(options.run, run);
  const core::RunConfig& config = run.config;
  const core::DemoDataset& data = *run.data;
  const auto& policy = run.policy;
  const nlohmann::json& best = run.best;
  const core::Standardizer& standardizer = data.standardizer();

  core::EvalConfig eval;
  eval.episodes = options.episodes > 0 ? options.episodes : config.eval_episodes;
  eval.threads = options.threads >= 0 ? options.threads : config.eval_threads;
  // The tasks scored: every task of the run, or eval.tasks of them (with their ids in the run's policy).
  std::vector<std::string> names;
  std::vector<double> expert_returns;
  const bool by_return = !envs::scored_by_success(data.task_set());
  for (int k = 0; k < data.num_tasks(); ++k) {
    const std::string& name = data.task_names()[k];
    if (!config.eval_tasks.empty() &&
        std::find(config.eval_tasks.begin(), config.eval_tasks.end(), name) == config.eval_tasks.end())
      continue;
    names.push_back(name);
    if (!config.eval_tasks.empty()) eval.task_ids.push_back(k);
    expert_returns.push_back(by_return ? data.demo_mean_return(k) : std::numeric_limits<double>::quiet_NaN());
  }
  for (const auto& name : config.eval_tasks)
    if (std::find(names.begin(), names.end(), name) == names.end())
      throw std::invalid_argument("eval.tasks: " + name + " is not a task of " + options.run);
  auto* maps_policy = dynamic_cast<core::MAPSPolicy*>(policy.get());
  if (options.each_module) {
    if (maps_policy == nullptr)
      throw std::invalid_argument("--each-module: " + options.run + " is a " + config.method +
                                  " run; only MAPS has modules");
    return evaluate_each_module(options.run, *maps_policy, data, names, expert_returns, eval, best);
  }
  const core::ModuleUsageFn usage = routing_of(*policy);
  std::printf("maps eval: %s, %d episodes per task\n", options.run.c_str(), eval.episodes);
  std::fflush(stdout);
  const core::EvaluationResult result = core::evaluate(*policy, standardizer, names, expert_returns, eval,
                                                       usage ? &usage : nullptr, progress_lines(names));

  nlohmann::json tasks = nlohmann::json::array();
  std::printf("| task | score (95%% CI) | return | success |\n|---|---|---|---|\n");
  for (std::size_t i = 0; i < result.tasks.size(); ++i) {
    const auto& t = result.tasks[i];
    std::printf("| %s | %.3f +- %.3f | %.1f +- %.1f | %.2f |\n", t.task.c_str(), t.score, t.score_ci95(), t.return_mean,
                t.return_std, t.success_rate);
    int demos = config.data.demos_per_task;  // the task's own count where data.task_demos sets one (transfer)
    for (const auto& [name, count] : config.data.task_demos)
      if (name == t.task) demos = count;
    nlohmann::json entry{{"task", t.task},
                         {"demos", demos},
                         {"episodes", t.episodes},
                         {"score", t.score},
                         {"score_ci95", t.score_ci95()},
                         {"return_mean", t.return_mean},
                         {"return_std", t.return_std},
                         {"return_mean_unclipped_cost", t.return_mean_unclipped_cost},
                         {"success_rate", t.success_rate},
                         {"final_success_rate", t.final_success_rate},
                         {"scored_by", by_return ? "return" : "success"},
                         {"returns", t.returns}};
    // The score's normaliser, so that a reader can put other returns (a GAIL run's training curve) on its scale.
    if (by_return) entry["expert_return"] = expert_returns.at(i);
    add_routing(entry, t);
    tasks.push_back(entry);
  }
  std::printf("mean score %.3f (%.1f s)\n", result.mean_score, result.seconds);
  nlohmann::json record{{"method", config.method},
                        {"seed", config.seed},
                        {"demos_per_task", config.data.demos_per_task},  // tasks[].demos: each task's own
                        {"subsample", config.data.subsample},
                        {"best_step", best.at("step")},
                        {"episodes", eval.episodes},
                        {"first_seed", eval.first_seed},
                        {"mean_score", result.mean_score},
                        {"seconds", result.seconds},
                        {"tasks", tasks}};
  if (options.checkpoints) {
    // Each kept checkpoint loaded and prepared afresh (MAML fine-tunes from the one loaded).
    nlohmann::json list = nlohmann::json::array();
    nlohmann::json best_over{
        {"step", best.at("step")}, {"mean_score", result.mean_score}, {"file", run_files::kBestCheckpoint}};
    for (const auto& [step, name] : kept) {
      TrainedRun at = load_trained_run(options.run, name);
      const core::EvaluationResult r =
          core::evaluate(*at.policy, at.data->standardizer(), names, expert_returns, eval, nullptr);
      list.push_back({{"step", step}, {"file", name}, {"mean_score", r.mean_score}, {"scores", task_scores(r)}});
      std::printf("checkpoint %s: mean score %.3f (%.1f s)\n", name.c_str(), r.mean_score, r.seconds);
      if (r.mean_score > best_over["mean_score"].get<double>())
        best_over = {{"step", step}, {"mean_score", r.mean_score}, {"file", name}};
    }
    record["checkpoints"] = list;
    record["best_over_checkpoints"] = best_over;
    std::printf("best over %zu checkpoints and best.ckpt (the paper's rule): %.3f at step %lld\n", kept.size(),
                best_over["mean_score"].get<double>(), best_over["step"].get<long long>());
  }
  if (final_policy) {
    const core::ModuleUsageFn last_usage = routing_of(*final_policy->policy);
    const core::EvaluationResult r = core::evaluate(*final_policy->policy, standardizer, names, expert_returns, eval,
                                                    last_usage ? &last_usage : nullptr);
    record["last"] = {{"step", final_policy->step}, {"mean_score", r.mean_score}, {"scores", task_scores(r)}};
    // A policy that routes: how it routes at its last step, beside best.ckpt's in tasks[] (the checkpoint rule can
    // pick a step before the selector's losses have shaped it).
    nlohmann::json routing = nlohmann::json::array();
    for (const auto& t : r.tasks) {
      if (t.module_usage.size() == 0) continue;
      nlohmann::json entry{{"task", t.task}};
      add_routing(entry, t);
      routing.push_back(entry);
    }
    if (!routing.empty()) record["last"]["routing"] = routing;
    std::printf("last step %lld (%s): mean score %.3f (%.1f s)\n", static_cast<long long>(final_policy->step),
                run_files::kLastCheckpoint, r.mean_score, r.seconds);
  }
  write_json_file((dir / run_files::kEval).string(), record);
  return 0;
}

}  // namespace maps::experiments
