#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <utility>
#include <vector>

#include "maps/data/demo_dataset.h"
#include "maps/policies/policy.h"
#include "nn/optim/adam.h"

// Training any Policy on a DemoDataset with Adam, with validation, the best-validation checkpoint, a progress
// line, a stop on a non-finite loss, and resumption.
//
// The run folder holds: step_<N>.ckpt (with keep_every: the policy at step N, config as best.ckpt's), last.ckpt
// (policy, Adam state, step, batch RNG and the best so far: what resume needs, written every checkpoint_every steps and
// at the end), best.ckpt (the policy at its lowest validation loss, whose config string is JSON with the step, its
// validation loss and the observation standardizer's mean and std), curve.csv (one row per validation: step, the
// training loss terms averaged since the last row, the validation BC loss, steps per second).
namespace maps::core {

struct TrainConfig {
  std::int64_t steps = 30000;  // the paper's code
  double learning_rate = 3e-4;
  std::int64_t states_per_task = 128;  // per task per batch (PAPER.md: 128 HalfCheetah, 32 MT10)
  std::int64_t validate_every = 1000;
  std::int64_t checkpoint_every = 1000;
  std::int64_t validation_states_per_task = 2000;  // evenly spaced through the validation demos
  // Every keep_every steps the policy is also kept as step_<N>.ckpt (0: never), so that every checkpoint can be
  // evaluated (`maps eval --checkpoints`: the paper's rule of the best test score over checkpoints).
  std::int64_t keep_every = 0;
  std::uint64_t seed = 0;  // the batch draws
  // "mean": the squared error of the mean action. "sampled": the paper's code's (Policy::use_sampled_bc_loss).
  // make_policy reads it; the trainer draws the noise seed of each step from `seed`.
  std::string bc_loss = "mean";
  // Parameters whose dotted name starts with one of these are not trained (transfer: "modules", "head").
  std::vector<std::string> freeze;
  // Learning-rate factors by name prefix (transfer: {"modules", 0.1}); the first prefix that matches applies.
  std::vector<std::pair<std::string, double>> lr_scale;
  // Training (steps and validation) flushes denormal floats to zero (autograd/float_environment.h): 3-6x faster
  // once MAPS's selector sharpens. false: IEEE denormals, as runs made before the option existed.
  bool flush_denormal = true;
  // The training steps' matrix products (autograd/matmul_precision.h): "float32", or "bf16" (bfloat16 operands,
  // float32 sums; CPUs with AVX512-BF16 only). Parameters, Adam's state, losses and validation stay float32.
  std::string precision = "float32";
  // "joint": one Adam step on every parameter per batch. "alternating": the paper's code's (train.py): on each batch
  // the selector's parameters take their step first, then the loss is computed again with the stepped selector
  // (a fresh sampled-BC noise draw) and every other parameter takes its step; one Adam state serves both. A policy
  // without parameters named "selector..." (the baselines, a uniform selector) cannot alternate.
  std::string optimizer = "joint";
  double adam_eps = 1e-8;  // torch's default; the paper's code 1e-5
  // The best checkpoint is judged on these tasks' validation states only (empty: every task's). Transfer's
  // comparison: a multi-task run taught a new task is judged on the new task, as a run of that task alone is.
  std::vector<std::string> validation_tasks;
  // Also judge the parameters the run starts from, as step 0 (a fresh run only; not a config key: `maps train` sets
  // it for a run that starts from another run's parameters, init.run). A transferred policy starts as a working
  // policy that training on a few demonstrations can make worse; without this, best.ckpt could only hold a trained
  // step. Step 0 gets no curve.csv row (it has no training losses); the log has its validation loss.
  bool validate_start = false;
  // An exponential moving average of the parameters (weight_average.h; Diffusion Policy evaluates one: power 0.75,
  // max decay 0.9999): with a power above 0 the average is what validation judges and best.ckpt and step_<N>.ckpt
  // keep; last.ckpt holds it beside the trained parameters. 0: no average (every method's default).
  double ema_power = 0.0;
  double ema_max_decay = 0.9999;
};

struct TrainSummary {
  std::int64_t steps_done = 0;
  std::int64_t best_step = -1;
  double best_validation_loss = 0.0;
  double seconds = 0.0;  // this process's training time
  // Of `seconds`: scoring the validation states, and writing checkpoints (last.ckpt, best.ckpt, kept step_*.ckpt):
  // the suite's overheads beside the steps (issue 44; docs/performance.md).
  double validation_seconds = 0.0;
  double checkpoint_seconds = 0.0;
  std::int64_t validations = 0, checkpoints_written = 0;
  bool resumed = false;
};

// One optimiser step of train_policy on `batch` (train.optimizer). "joint": the loss is differentiated once and
// `adam` steps every parameter. "alternating" (the paper's code): the parameters flagged in `selector` step first,
// then the loss is computed again with the stepped selector (batch.noise_seed advanced: a fresh sampled-BC draw)
// and the others step. Returns the loss before any update, or, when that is finite but the loss after the
// selector's step is not, the latter (the selector has then stepped, the others not). A non-finite loss steps
// nothing. `adam` must hold `params`, in order.
LossTerms optimizer_step(Policy& policy, Batch& batch, const std::vector<ag::Tensor>& params,
                         const std::vector<bool>& selector, optim::Adam& adam, const std::string& optimizer);

// The steps run_dir/last.ckpt has trained (0 when there is none yet).
std::int64_t trained_steps(const std::string& run_dir);

// Trains (or resumes from run_dir/last.ckpt), then loads best.ckpt into `policy`. `log` gets the progress lines
// (nullptr: silent). A non-finite loss throws std::runtime_error naming the step and the term, with last.ckpt
// left at the last good checkpoint.
TrainSummary train_policy(Policy& policy, const DemoDataset& data, const TrainConfig& config,
                          const std::string& run_dir, std::ostream* log);

}  // namespace maps::core
