#pragma once

#include <string>

namespace maps::experiments {

// `maps eval --run DIR`: rolls the run's best policy out on held-out initial states of every task and writes
// DIR/eval.json (per task: score, return, success rate, MAPS's module usage).
struct EvalRunOptions {
  std::string run;
  int episodes = 0;  // 0: the run config's
  int threads = -1;  // -1: the run config's
  // Also evaluate every step_<N>.ckpt the run kept (train.keep_every), into eval.json's "checkpoints" and
  // "best_over_checkpoints" (the paper's rule: the best test score over checkpoints, an optimistic one).
  bool checkpoints = false;
  // Also evaluate the policy after the last training step (last.ckpt; with train.ema_power its average of the
  // weights), into eval.json's "last": the final-checkpoint rule, beside the best-validation one.
  bool last = false;
  // MAPS only: instead of eval.json, evaluate the policy once with its selector and once with every score forced
  // onto each module in turn (Fig. 6: what each module does alone), into DIR/eval_modules.json.
  bool each_module = false;
};

int run_eval(const EvalRunOptions& options);

}  // namespace maps::experiments
