#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace maps::experiments {

// `maps transfer --run RUN --task T --demos n --out DIR`: teaches a MAPS run trained without task T to do T from n
// of T's demonstrations, reusing its modules (docs/transfer.md). Writes DIR/request.json (the run config: the
// source's, for T alone, starting from RUN's best.ckpt) and trains it as `maps train` does; `maps eval --run DIR`
// then evaluates it on T.
struct TransferOptions {
  std::string run;
  std::string task;
  int demos = 0;
  std::string out;
  std::string freeze = "modules";  // "modules", "modules,head", "head" or "none"
  double module_lr_scale = 1.0;    // with the modules trained: their learning rate's factor
  std::optional<std::uint64_t> seed;
  std::optional<std::int64_t> steps;
  int threads = 1;
};

int run_transfer(const TransferOptions& options);

}  // namespace maps::experiments
