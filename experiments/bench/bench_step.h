#pragma once

#include <string>

namespace maps::experiments {

// `maps bench step --set gravity|modified|mt10 [--method NAME]`: times one whole training step of a method (MAPS:
// forward, the BC loss and the four selector losses, backward, Adam) at the paper's shapes for the set, counts its GEMM
// FLOPs analytically, and compares both with Eigen's float32 GEMM timed in the same run (and, with --vs-pytorch, with
// the same step in PyTorch: experiments/bench/peer_pytorch.py).
struct BenchStepOptions {
  std::string set = "gravity";
  std::string method = "maps";  // any registered method (policy_registry.h), at its defaults
  int threads = 1;
  bool json = false;
  bool vs_pytorch = false;
  double seconds = 2.0;  // time spent in timed steps (after warm-up)
  // The step's matrix products (train.precision): "float32" or "bf16"; empty: the config's (float32 by default).
  // maps's own GEMM reference is timed in the same precision.
  std::string precision;
  // A partial run config merged over the method's defaults (--config): its plugins loaded, e.g. a selector loss of
  // a plugin added to MAPS's four ({"plugins": [...], "maps": {"selector_losses": {"task_overlap": 0.5}}}).
  std::string config_path;
};

int run_bench_step(const BenchStepOptions& options);

}  // namespace maps::experiments
