#pragma once

#include <string>

namespace maps::experiments {

// `maps eval --run DIR`: rolls the run's best policy out on held-out initial states of every task and writes
// DIR/eval.json (per task: score, return, success rate, MAPS's module usage).
struct EvalRunOptions {
  std::string run;
  int episodes = 0;  // 0: the run config's
  int threads = -1;  // -1: the run config's
};

int run_eval(const EvalRunOptions& options);

}  // namespace maps::experiments
