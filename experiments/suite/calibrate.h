#pragma once

#include <string>
#include <vector>

namespace maps::experiments {

// `maps suite calibrate [--out F] [--steps S] [--episodes E] [--sets ...] [--methods ...] [--suite F]`: trains and
// evaluates every method (each choice of its cost option apart) on every set briefly, timing each, and writes the cost
// table, keeping the entries it did not re-measure.
struct SuiteCalibrateOptions {
  std::string out;  // "" : default_costs_path()
  std::string work = "runs/calibrate";
  int steps = 400;
  // The evaluator steps up to 10 episodes of a task together (one batched policy call a step): fewer would time a
  // policy call on fewer rows than a suite's 100-episode evaluation makes, and overstate an episode's cost 2-3x.
  int episodes = 10;
  std::vector<std::string> sets;     // empty: every set (envs::task_set_names())
  std::vector<std::string> methods;  // empty: every registered method
  // The suite whose per-set settings (demo file, batch, selector weights, the first demo count) are timed; "":
  // experiments/suites/paper.json.
  std::string suite;
  // > 0: also time every method that trains by GAIL (not MAML, not a policy of action chunks) for this many env steps
  // per task (the default gail settings, warm-up off; the warm-up's discriminator steps are priced apart).
  std::int64_t gail_env_steps = 0;
};
int run_suite_calibrate(const SuiteCalibrateOptions& options);

}  // namespace maps::experiments
