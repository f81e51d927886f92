// `maps bench step|eval`: the library's hot paths timed.

#include <memory>

#include "autograd/matmul_precision.h"
#include "experiments/bench/bench_eval.h"
#include "experiments/bench/bench_step.h"
#include "experiments/cli/command.h"
#include "experiments/cli/options.h"

namespace maps::experiments::cli {
namespace {

void add_bench_step(CLI::App* bench, Commands& commands) {
  auto options = std::make_shared<BenchStepOptions>();
  CLI::App* command = bench->add_subcommand(
      "step", "Time one whole MAPS training step at the paper's shapes against Eigen's GEMM (and PyTorch)");
  add_task_set(command, options->set)->capture_default_str();  // the set's shapes
  command
      ->add_option("--method", options->method, "The method whose step is timed, at its defaults (maps train --help)")
      ->capture_default_str();
  command
      ->add_option("--config", options->config_path,
                   "A partial run config over the method's defaults, its plugins loaded (a plugin's selector loss "
                   "added to MAPS's: {\"plugins\": [...], \"maps\": {\"selector_losses\": {...}}})")
      ->check(CLI::ExistingFile);
  command
      ->add_option("--precision", options->precision,
                   "The step's matrix products, as train.precision: float32 or bf16 (AVX512-BF16 CPUs); default: "
                   "the config's, float32")
      ->check(CLI::IsMember(ag::matmul_precision_names()));
  add_threads(command, options->threads, "Threads (0: one per core)");
  add_positive(command, "--seconds", options->seconds, "Time spent in timed steps");
  command->add_flag("--json", options->json, "Print one JSON object");
  command->add_flag("--vs-pytorch", options->vs_pytorch,
                    "Also time the same step in PyTorch (experiments/bench/peer_pytorch.py)");
  commands.push_back({command, [options] {
                        options->threads = threads_or_cores(options->threads);
                        return run_bench_step(*options);
                      }});
}

void add_bench_eval(CLI::App* bench, Commands& commands) {
  auto options = std::make_shared<BenchEvalOptions>();
  CLI::App* command = bench->add_subcommand(
      "eval", "Time an evaluation of a method's policy (fresh weights) on a task set and show where the time goes");
  add_task_set(command, options->set)->capture_default_str();
  command
      ->add_option("--method", options->method,
                   "The method whose policy is evaluated, at its defaults (maps train --help)")
      ->capture_default_str();
  command->add_option("--config", options->config_path, "A partial run config over the method's defaults")
      ->check(CLI::ExistingFile);
  add_positive(command, "--episodes", options->episodes, "Episodes per task");
  add_threads(command, options->threads, "Evaluator threads (0: one per core)");
  add_positive(command, "--max-envs", options->max_envs, "Envs alive per task");
  command->add_flag("--json", options->json, "Print one JSON object");
  commands.push_back({command, [options] {
                        options->threads = threads_or_cores(options->threads);
                        return run_bench_eval(*options);
                      }});
}

}  // namespace

void add_bench(CLI::App& tool, Commands& commands) {
  CLI::App* bench = tool.add_subcommand("bench", "Time the library's hot paths");
  bench->require_subcommand(1);
  add_bench_step(bench, commands);
  add_bench_eval(bench, commands);
}

}  // namespace maps::experiments::cli
