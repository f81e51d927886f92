// The `maps` command-line tool. Each subcommand parses its options here and dispatches to a
// function declared in its own header under experiments/.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <exception>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>

#include "experiments/bench_eval.h"
#include "experiments/bench_step.h"
#include "experiments/collect.h"
#include "experiments/data_convert.h"
#include "experiments/demo.h"
#include "experiments/eval_run.h"
#include "experiments/expert_eval.h"
#include "experiments/provenance.h"
#include "experiments/render.h"
#include "experiments/schema_command.h"
#include "experiments/suite_costs.h"
#include "experiments/suite_run.h"
#include "experiments/suite_status.h"
#include "experiments/train_expert.h"
#include "experiments/train_run.h"
#include "experiments/transfer_run.h"
#include "experiments/usage_error.h"
#include "experiments/version.h"
#include "maps/policies/policy_registry.h"

namespace {

// Sign checks with short messages ("--steps: must be a number > 0, got '-3'"). CLI11's PositiveNumber prints
// DBL_MAX in full, and CLI11 2.1 turns "-1" into 2^64-1 for an unsigned option without a check. Infinities and
// NaN are refused too: "--seconds inf" ran `bench step` forever, "--lr inf" trained to NaN.
CLI::Validator sign_check(bool allow_zero) {
  return CLI::Validator(
      [allow_zero](std::string& input) -> std::string {
        double value = 0.0;
        if (CLI::detail::lexical_cast(input, value) && std::isfinite(value) &&
            (value > 0.0 || (allow_zero && value == 0.0)))
          return {};
        return std::string(allow_zero ? "must be a finite number >= 0" : "must be a finite number > 0") + ", got '" +
               input + "'";
      },
      allow_zero ? "NONNEGATIVE" : "POSITIVE");
}

// Seeds are 64-bit unsigned; CLI11 2.1 saturates a larger number to 2^64-1 without a word.
CLI::Validator seed_check() {
  return CLI::Validator(
      [](std::string& input) -> std::string {
        std::uint64_t value = 0;
        const auto [end, error] = std::from_chars(input.data(), input.data() + input.size(), value);
        if (!input.empty() && error == std::errc() && end == input.data() + input.size()) return {};
        return "must be an integer in [0, 18446744073709551615], got '" + input + "'";
      },
      "UINT64");
}

// A 64-bit integer option: CLI11 2.1 saturates a number past int64's range instead of refusing it.
CLI::Validator integer_check(std::int64_t low, std::int64_t high) {
  return CLI::Validator(
      [low, high](std::string& input) -> std::string {
        std::int64_t value = 0;
        const auto [end, error] = std::from_chars(input.data(), input.data() + input.size(), value);
        if (!input.empty() && error == std::errc() && end == input.data() + input.size() && value >= low &&
            value <= high)
          return {};
        return "must be an integer in [" + std::to_string(low) + ", " + std::to_string(high) + "], got '" + input + "'";
      },
      "INT in [" + std::to_string(low) + " - " + std::to_string(high) + "]");
}

// CLI::Range lets NaN through (every comparison with it is false).
CLI::Validator range_check(double low, double high) {
  const auto text = [](double x) {
    std::ostringstream out;
    out << x;
    return out.str();
  };
  return CLI::Validator(
      [low, high, text](std::string& input) -> std::string {
        double value = 0.0;
        if (CLI::detail::lexical_cast(input, value) && value >= low && value <= high) return {};
        return "must be a number in [" + text(low) + ", " + text(high) + "], got '" + input + "'";
      },
      "FLOAT in [" + text(low) + " - " + text(high) + "]");
}

}  // namespace

int main(int argc, char** argv) {
  const CLI::Validator positive = sign_check(false);
  const CLI::Validator non_negative = sign_check(true);
  // 0: one per core (at most ag::kMaxThreads); a larger count is refused (a billion threads ended in std::terminate).
  const CLI::Validator thread_count = integer_check(0, maps::ag::kMaxThreads);
  // Cells at once are processes, each with its own threads: a cluster node or a plan may count far more of them.
  const CLI::Validator job_count = integer_check(0, 65536);

  CLI::App app{"maps: multi-task imitation learning on a from-scratch autograd engine"};
  app.name("maps");
  // The version, the commit and what the build computes with: what a bug report or a speed figure needs.
  app.set_version_flag("--version", [] {
    return std::string("maps ") + maps::experiments::tool_version() + "\ncommit " +
           maps::experiments::tool_git_commit() + "\nbuild " + MAPS_BUILD_DESCRIPTION + "\nfloat32 GEMM kernel " +
           maps::ag::float32_gemm_kernel();
  });
  app.require_subcommand(0, 1);

  maps::experiments::DemoOptions demo;
  CLI::App* demo_cmd =
      app.add_subcommand("demo", "Train a small tanh MLP on a synthetic regression and print the loss falling");
  demo_cmd->add_option("--steps", demo.steps, "Optimiser steps")->check(positive)->capture_default_str();
  demo_cmd->add_option("--seed", demo.seed, "Seed of the data and the initial weights")
      ->check(seed_check())
      ->capture_default_str();
  demo_cmd->add_option("--hidden", demo.hidden, "Hidden width")->check(range_check(1, 65536))->capture_default_str();
  demo_cmd->add_option("--lr", demo.lr, "Adam learning rate")->check(positive)->capture_default_str();
  demo_cmd->add_option("--log-every", demo.log_every, "Print the loss every N steps")
      ->check(positive)
      ->capture_default_str();

  maps::experiments::TrainExpertOptions train_expert;
  CLI::App* train_expert_cmd = app.add_subcommand(
      "train-expert", "Train a HalfCheetah expert with PPO, resuming from DIR's checkpoint; writes DIR/expert.json");
  train_expert_cmd->add_option("--task", train_expert.task, "Task name, e.g. gravity/0.5")->required();
  train_expert_cmd->add_option("--out", train_expert.out, "Run folder (checkpoint, expert.json)")->required();
  train_expert_cmd->add_option("--steps", train_expert.steps, "Total env steps")
      ->check(integer_check(1, 1'000'000'000'000))
      ->capture_default_str();
  train_expert_cmd->add_option("--seed", train_expert.seed, "Seed")->check(seed_check())->capture_default_str();
  train_expert_cmd->add_option("--checkpoint-every", train_expert.checkpoint_every, "Iterations between checkpoints")
      ->check(positive)
      ->capture_default_str();
  train_expert_cmd->add_option("--eval-episodes", train_expert.eval_episodes, "Deterministic episodes at the end")
      ->check(positive)
      ->capture_default_str();
  train_expert_cmd->add_option("--lr", train_expert.learning_rate, "Adam's initial learning rate (annealed to 0)")
      ->check(positive)
      ->capture_default_str();
  train_expert_cmd->add_option("--init", train_expert.init,
                               "Warm start from another run's checkpoint.ckpt (when DIR has none)");
  train_expert_cmd
      ->add_option("--abandon-flipped", train_expert.abandon_flipped,
                   "Past this many steps, stop (exit 3) once the last 5 rollouts ran on the back; 0: never")
      ->check(integer_check(0, 1'000'000'000'000))
      ->capture_default_str();
  train_expert_cmd
      ->add_option("--end-at-pitch", train_expert.end_at_pitch,
                   "End a training episode (terminated, not bootstrapped) once the torso's |pitch| exceeds this many "
                   "radians (1.5708: turned over); 0: never")
      ->check(range_check(0.0, 3.14159265358979))
      ->capture_default_str();

  maps::experiments::CollectOptions collect;
  CLI::App* collect_cmd = app.add_subcommand(
      "collect", "Roll a task set's committed experts out into demonstrations (HDF5, 70/30 train/valid per task)");
  collect_cmd->add_option("--set", collect.task_set, "Task set: gravity, modified or mt10")
      ->required()
      ->check(CLI::IsMember({"gravity", "modified", "mt10"}));
  collect_cmd->add_option("--demos", collect.demos, "Kept demonstrations per task")
      ->check(positive)
      ->capture_default_str();
  collect_cmd->add_option("--out", collect.out, "HDF5 file to write")->required();
  collect_cmd->add_flag("--force", collect.force, "Replace --out if it exists");
  collect_cmd->add_option("--actions", collect.actions, "Record the expert's mean action or a sampled one")
      ->check(CLI::IsMember({"mean", "sample"}))
      ->capture_default_str();
  collect_cmd->add_option("--experts", collect.experts_dir,
                          "Folder of <set>/<task>.json experts (default: envs/experts)");
  collect_cmd->add_option("--first-seed", collect.first_seed, "First reset seed of the demonstrations")
      ->check(seed_check())
      ->capture_default_str();
  collect_cmd
      ->add_option("--min-return-fraction", collect.min_return_fraction,
                   "Discard an episode returning less than this fraction of the task's median (not for mt10)")
      ->check(range_check(0.0, 1.0))
      ->capture_default_str();
  collect_cmd->add_option("--train-fraction", collect.train_fraction, "Share of each task's demos in mask/train")
      ->check(range_check(0.0, 1.0))
      ->capture_default_str();
  collect_cmd->add_option("--split-seed", collect.split_seed, "Seed of the train/valid split")
      ->check(seed_check())
      ->capture_default_str();
  collect_cmd->add_option("--threads", collect.threads, "Tasks rolled out at once (0: one per core)")
      ->check(thread_count)
      ->capture_default_str();

  maps::experiments::RenderOptions render;
  CLI::App* render_cmd =
      app.add_subcommand("render",
                         "Draw a task's scene offscreen (MuJoCo's renderer on OSMesa) to PNG, or a trained policy's "
                         "episode to a PNG strip or an animated GIF");
  render_cmd->add_option("--task", render.task, "Task name, e.g. mt10/door-open or gravity/1.0")->required();
  auto* render_seed = render_cmd
                          ->add_option("--seed", render.seed,
                                       "Seed of the initial state (with --run: default the first evaluation seed)")
                          ->check(seed_check())
                          ->capture_default_str();
  render_cmd->add_option("--out", render.out, "PNG file to write (with --run, a .gif name: the episode animated)")
      ->required();
  render_cmd->add_option("--steps", render.steps, "Steps of the task's expert before the picture")
      ->check(non_negative)
      ->capture_default_str();
  render_cmd->add_option("--width", render.width, "Width in pixels (at most 640)")
      ->check(positive)
      ->capture_default_str();
  render_cmd->add_option("--height", render.height, "Height in pixels (at most 480)")
      ->check(positive)
      ->capture_default_str();
  render_cmd->add_option("--camera", render.camera, "A named camera of the model (default: a view made for the task)");
  render_cmd
      ->add_option("--run", render.run,
                   "A trained run folder: a strip of frames of its policy's episode instead of the expert")
      ->check(CLI::ExistingDirectory);
  render_cmd->add_option("--module", render.module, "With --run of MAPS: every selector score on this module")
      ->check(non_negative);
  render_cmd
      ->add_option("--every", render.every,
                   "With --run and --out x.gif: a frame every N steps (0: about 150 frames in all)")
      ->check(non_negative)
      ->capture_default_str();
  render_cmd->add_option("--frames", render.frames, "With --run: frames in the strip, spread over the episode")
      ->check(positive)
      ->capture_default_str();

  maps::experiments::ExpertEvalOptions expert_eval;
  CLI::App* expert_eval_cmd = app.add_subcommand(
      "expert-eval", "Score each task's expert (mean action) from evaluation seeds: return, success, turned over");
  auto* eval_set = expert_eval_cmd->add_option("--set", expert_eval.task_set, "Task set: gravity, modified or mt10")
                       ->check(CLI::IsMember({"gravity", "modified", "mt10"}));
  auto* eval_task = expert_eval_cmd->add_option("--task", expert_eval.task, "One task instead of a set");
  eval_set->excludes(eval_task);
  expert_eval_cmd->add_option("--episodes", expert_eval.episodes, "Episodes per task")
      ->check(positive)
      ->capture_default_str();
  expert_eval_cmd->add_option("--first-seed", expert_eval.first_seed, "Reset seed of the first episode")
      ->check(seed_check())
      ->capture_default_str();
  expert_eval_cmd->add_option("--threads", expert_eval.threads, "Tasks evaluated at once (0: one per core)")
      ->check(thread_count)
      ->capture_default_str();
  expert_eval_cmd->add_option("--out", expert_eval.out, "Also write the table to this JSON file");
  expert_eval_cmd->add_flag("--json", expert_eval.json, "Print the table as one JSON array (the text goes to stderr)");

  maps::experiments::TrainRunOptions train_run;
  CLI::App* train_cmd = app.add_subcommand("train", "Train one method on a demo file as a JSON config says");
  std::string method_lines = "Methods (config \"method\"; docs/configs.md, docs/zoo.md):";
  for (const auto& method : maps::core::policy_methods())
    method_lines +=
        "\n  " + method.name + std::string(method.name.size() < 10 ? 10 - method.name.size() : 1, ' ') + method.summary;
  train_cmd->footer(method_lines);
  train_cmd->add_option("--config", train_run.config_path, "Run config (JSON; every key in docs/configs.md)")
      ->required()
      ->check(CLI::ExistingFile);
  train_cmd->add_option("--out", train_run.out,
                        "Run folder (resumes a run of the same config; a finished one is extended when only "
                        "train.steps grew)");
  train_cmd->add_option("--set", train_run.overrides,
                        "Override a config key: --set train.steps=40000 --set maps.modules=5 (repeatable)");
  train_cmd->add_flag("--print-config", train_run.print_config,
                      "Print the resolved config (every key, defaults included) and exit without training");
  train_cmd
      ->add_option("--threads", train_run.threads,
                   "Op threads for the training steps (0: one per core; docs/performance.md)")
      ->check(thread_count)
      ->capture_default_str();

  maps::experiments::TransferOptions transfer;
  CLI::App* transfer_cmd = app.add_subcommand(
      "transfer", "Teach a MAPS run trained without task T to do T from a few demonstrations, reusing its modules");
  transfer_cmd->add_option("--run", transfer.run, "A MAPS run folder trained without --task (data.holdout)")
      ->required()
      ->check(CLI::ExistingDirectory);
  transfer_cmd->add_option("--task", transfer.task, "The new task, e.g. gravity/0.5")->required();
  transfer_cmd->add_option("--demos", transfer.demos, "Training demonstrations of the new task")
      ->required()
      ->check(positive);
  transfer_cmd->add_option("--out", transfer.out, "Run folder to write (resumes)")->required();
  transfer_cmd->add_option("--freeze", transfer.freeze, "What stays as trained: modules, modules,head, head or none")
      ->capture_default_str();
  transfer_cmd
      ->add_option("--module-lr-scale", transfer.module_lr_scale,
                   "With the modules trained (--freeze none or head): their learning rate's factor")
      ->check(non_negative)
      ->capture_default_str();
  transfer_cmd->add_option("--seed", transfer.seed, "Seed (default: the source run's)")->check(seed_check());
  transfer_cmd->add_option("--steps", transfer.steps, "Training steps (default: the source run's)")
      ->check(integer_check(1, 1'000'000'000'000));
  transfer_cmd->add_option("--threads", transfer.threads, "Op threads (0: one per core)")
      ->check(thread_count)
      ->capture_default_str();

  maps::experiments::EvalRunOptions eval_run;
  CLI::App* eval_cmd = app.add_subcommand("eval", "Evaluate a trained run on held-out initial states");
  eval_cmd->add_option("--run", eval_run.run, "Run folder written by maps train")
      ->required()
      ->check(CLI::ExistingDirectory);
  eval_cmd->add_option("--episodes", eval_run.episodes, "Episodes per task (default: the run config's)")
      ->check(positive);
  eval_cmd->add_option("--threads", eval_run.threads, "Threads (0: one per core; default: the run config's)")
      ->check(thread_count);
  eval_cmd->add_flag(
      "--checkpoints", eval_run.checkpoints,
      "Also evaluate every kept step_<N>.ckpt (train.keep_every): the paper's best-over-checkpoints rule");
  eval_cmd
      ->add_flag("--each-module", eval_run.each_module,
                 "MAPS: score every task with the selector forced onto each module in turn, into eval_modules.json "
                 "(eval.json is left alone)")
      ->excludes("--checkpoints");

  CLI::App* bench_cmd = app.add_subcommand("bench", "Time the library's hot paths");
  bench_cmd->require_subcommand(1);
  maps::experiments::BenchStepOptions bench_step;
  CLI::App* bench_step_cmd = bench_cmd->add_subcommand(
      "step", "Time one whole MAPS training step at the paper's shapes against Eigen's GEMM (and PyTorch)");
  bench_step_cmd->add_option("--set", bench_step.set, "Shapes: gravity, modified or mt10")->capture_default_str();
  bench_step_cmd
      ->add_option("--method", bench_step.method, "The method whose step is timed, at its defaults (maps train --help)")
      ->capture_default_str();
  bench_step_cmd->add_option("--threads", bench_step.threads, "Threads (0: one per core)")
      ->check(thread_count)
      ->capture_default_str();
  bench_step_cmd->add_option("--seconds", bench_step.seconds, "Time spent in timed steps")
      ->check(positive)
      ->capture_default_str();
  bench_step_cmd->add_flag("--json", bench_step.json, "Print one JSON object");
  bench_step_cmd->add_flag("--vs-pytorch", bench_step.vs_pytorch,
                           "Also time the same step in PyTorch (experiments/benchmarks/peer_pytorch.py)");

  maps::experiments::BenchEvalOptions bench_eval;
  CLI::App* bench_eval_cmd = bench_cmd->add_subcommand(
      "eval", "Time an evaluation of a MAPS policy on a task set and show where the time goes");
  bench_eval_cmd->add_option("--set", bench_eval.set, "Task set: gravity, modified or mt10")->capture_default_str();
  bench_eval_cmd->add_option("--episodes", bench_eval.episodes, "Episodes per task")
      ->check(positive)
      ->capture_default_str();
  bench_eval_cmd->add_option("--threads", bench_eval.threads, "Evaluator threads (0: one per core)")
      ->check(thread_count)
      ->capture_default_str();
  bench_eval_cmd->add_option("--max-envs", bench_eval.max_envs, "Envs alive per task")
      ->check(positive)
      ->capture_default_str();
  bench_eval_cmd->add_flag("--json", bench_eval.json, "Print one JSON object");

  CLI::App* suite_cmd = app.add_subcommand(
      "suite", "The comparison suite: a grid of train + eval cells from a suite config (experiments/suites/*.json)");
  suite_cmd->require_subcommand(1);
  maps::experiments::SuitePlanOptions suite_plan;
  CLI::App* suite_plan_cmd =
      suite_cmd->add_subcommand("plan", "Print a suite's cells, their count and the estimated CPU time");
  suite_plan_cmd->add_option("config", suite_plan.config_path, "Suite config (JSON)")
      ->required()
      ->check(CLI::ExistingFile);
  suite_plan_cmd
      ->add_option("--shard", suite_plan.shard,
                   "Only the cells with index % N == i (a transfer cell: its source's index)")
      ->capture_default_str();
  suite_plan_cmd->add_option("--jobs", suite_plan.jobs, "Cells at once, for the wall-time estimate (0: cores)")
      ->check(job_count);
  suite_plan_cmd->add_flag("--cells", suite_plan.list_cells, "List every cell");
  suite_plan_cmd->add_flag("--json", suite_plan.json, "Print one JSON object (every cell and the estimate)");
  suite_plan_cmd->add_option("--costs", suite_plan.costs, "Cost table (default: experiments/suites/costs.json)");

  maps::experiments::SuiteRunOptions suite_run;
  CLI::App* suite_run_cmd = suite_cmd->add_subcommand(
      "run", "Run a suite's cells (resumable: finished cells are skipped, unfinished ones resume)");
  suite_run_cmd->add_option("config", suite_run.config_path, "Suite config (JSON)")
      ->required()
      ->check(CLI::ExistingFile);
  suite_run_cmd->add_option("--out", suite_run.out, "Suite folder")->required();
  suite_run_cmd->add_option("--jobs", suite_run.jobs, "Cells at once (0: cores / threads)")
      ->check(job_count)
      ->capture_default_str();
  suite_run_cmd->add_option("--threads", suite_run.threads, "Op threads per cell (0: one per core)")
      ->check(thread_count)
      ->capture_default_str();
  suite_run_cmd
      ->add_option("--shard", suite_run.shard,
                   "Run only the cells with index % N == i (i/N; a transfer cell: its source's index)")
      ->capture_default_str();
  suite_run_cmd->add_option("--costs", suite_run.costs, "Cost table for the ETA");

  std::string prepare_config;
  int prepare_threads = 0;
  CLI::App* suite_prepare_cmd =
      suite_cmd->add_subcommand("prepare", "Collect the suite's missing demonstration files (before a cluster run)");
  suite_prepare_cmd->add_option("config", prepare_config, "Suite config (JSON)")->required()->check(CLI::ExistingFile);
  suite_prepare_cmd->add_option("--threads", prepare_threads, "Tasks rolled out at once (0: one per core)")
      ->check(thread_count);

  maps::experiments::SuiteStatusOptions suite_status;
  CLI::App* suite_status_cmd =
      suite_cmd->add_subcommand("status", "Say which cells of a suite folder are done, running, failed or left");
  suite_status_cmd->add_option("dirs", suite_status.dirs, "Suite folder, or the shard folders of one suite")
      ->required()
      ->check(CLI::ExistingDirectory);
  suite_status_cmd->add_flag("--all", suite_status.all, "One line per cell");
  suite_status_cmd->add_flag("--json", suite_status.json, "Print one JSON object");

  maps::experiments::SuiteMergeOptions suite_merge;
  CLI::App* suite_merge_cmd =
      suite_cmd->add_subcommand("merge", "Copy the finished cells of shard folders of one suite into one folder");
  suite_merge_cmd->add_option("--out", suite_merge.out, "Merged suite folder")->required();
  suite_merge_cmd->add_option("shards", suite_merge.shards, "Shard folders")->required()->check(CLI::ExistingDirectory);

  maps::experiments::SuiteCalibrateOptions suite_calibrate;
  CLI::App* suite_calibrate_cmd = suite_cmd->add_subcommand(
      "calibrate", "Time a short run of every method on every set and write the cost table plan and run use");
  suite_calibrate_cmd->add_option("--out", suite_calibrate.out, "Cost table (default: experiments/suites/costs.json)");
  suite_calibrate_cmd->add_option("--work", suite_calibrate.work, "Folder for the timed runs")->capture_default_str();
  suite_calibrate_cmd->add_option("--steps", suite_calibrate.steps, "Training steps per timed run")
      ->check(positive)
      ->capture_default_str();
  suite_calibrate_cmd->add_option("--episodes", suite_calibrate.episodes, "Evaluation episodes per task")
      ->check(positive)
      ->capture_default_str();
  suite_calibrate_cmd->add_option("--sets", suite_calibrate.sets, "Task sets to time")
      ->check(CLI::IsMember({"gravity", "modified", "mt10"}));

  maps::experiments::ReportOptions report;
  CLI::App* report_cmd = app.add_subcommand(
      "report", "Write a suite folder's results.csv, report.md and the paper's figures (experiments/suites/report.py)");
  report_cmd->add_option("dir", report.dir, "Suite folder")->required()->check(CLI::ExistingDirectory);
  report_cmd->add_option("--out", report.out, "Report folder (default: DIR/report)");

  maps::experiments::DataConvertOptions data_export, data_import;
  CLI::App* data_cmd =
      app.add_subcommand("data", "Demo files to and from D4RL, Minari and robomimic (docs/interop.md)");
  data_cmd->require_subcommand(1);
  CLI::App* data_export_cmd = data_cmd->add_subcommand("export", "Write a demo file in another tool's format");
  data_export_cmd->add_option("--format", data_export.format, "d4rl, minari or robomimic")
      ->required()
      ->check(CLI::IsMember({"d4rl", "minari", "robomimic"}));
  data_export_cmd->add_option("input", data_export.input, "Demo file (format 2)")->required()->check(CLI::ExistingFile);
  data_export_cmd->add_option("--out", data_export.out, "The file to write (Minari: the dataset folder)")->required();
  data_export_cmd->add_option("--dataset-id", data_export.dataset_id,
                              "Minari's dataset id (default maps/<set>/expert-v0)");
  CLI::App* data_import_cmd = data_cmd->add_subcommand("import", "Make a demo file from another tool's dataset");
  data_import_cmd->add_option("--format", data_import.format, "d4rl, minari or robomimic")
      ->required()
      ->check(CLI::IsMember({"d4rl", "minari", "robomimic"}));
  data_import_cmd->add_option("input", data_import.input, "The dataset (a file; Minari: its dataset folder)")
      ->required()
      ->check(CLI::ExistingPath);
  data_import_cmd->add_option("--out", data_import.out, "Demo file to write")->required();
  data_import_cmd->add_flag("--force", data_import.force, "Replace --out if it exists");
  data_import_cmd->add_option("--task-set", data_import.task_set,
                              "Set name for a dataset made elsewhere (default: its file or dataset name)");
  data_import_cmd->add_option("--obs-keys", data_import.obs_keys,
                              "robomimic: observation keys, comma-separated, in column order (default: all, sorted)");

  maps::experiments::SchemaOptions schema;
  CLI::App* schema_cmd = app.add_subcommand(
      "schema", "Every key of an input with its type, default, range and meaning (docs/configs.md's table)");
  schema_cmd
      ->add_option("kind", schema.kind,
                   "The input: run-config, suite-config, policy-checkpoint (best.ckpt's record), "
                   "training-checkpoint (last.ckpt's) or expert (an expert file)")
      ->required()
      ->check(CLI::IsMember({"run-config", "suite-config", "policy-checkpoint", "training-checkpoint", "expert"}));
  schema_cmd->add_flag("--markdown", schema.markdown, "The docs' markdown table instead of JSON");

  // Exit codes (docs/cli.md): 0 done, 1 the work failed (bad input files, a failed run), 2 the command line is wrong
  // (CLI11's own codes, 105-109 by kind, are folded into 2), 3 `suite run` left cells to another process.
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help is a ParseError that exits 0
  }
  render.seed_given = render_seed->count() > 0;
  for (int i = 0; i < argc; ++i) collect.command_line += (i ? " " : "") + std::string(argv[i]);
  maps::experiments::set_command_line(argc, argv);
  // --threads 0 means one per core in every command; these take the count as given.
  for (int* threads :
       {&train_run.threads, &bench_step.threads, &bench_eval.threads, &suite_run.threads, &transfer.threads})
    if (*threads == 0)
      *threads = std::min(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())), maps::ag::kMaxThreads);

  try {
    if (*demo_cmd) return maps::experiments::run_demo(demo);
    if (*train_expert_cmd) return maps::experiments::run_train_expert(train_expert);
    if (*collect_cmd) return maps::experiments::run_collect(collect);
    if (*render_cmd) return maps::experiments::run_render(render);
    if (*expert_eval_cmd) return maps::experiments::run_expert_eval(expert_eval);
    if (*train_cmd) return maps::experiments::run_train(train_run);
    if (*transfer_cmd) return maps::experiments::run_transfer(transfer);
    if (*eval_cmd) return maps::experiments::run_eval(eval_run);
    if (*bench_step_cmd) return maps::experiments::run_bench_step(bench_step);
    if (*bench_eval_cmd) return maps::experiments::run_bench_eval(bench_eval);
    if (*suite_plan_cmd) return maps::experiments::run_suite_plan(suite_plan);
    if (*suite_run_cmd) return maps::experiments::run_suite(suite_run);
    if (*suite_prepare_cmd) return maps::experiments::run_suite_prepare(prepare_config, prepare_threads);
    if (*suite_status_cmd) return maps::experiments::run_suite_status(suite_status);
    if (*suite_merge_cmd) return maps::experiments::run_suite_merge(suite_merge);
    if (*suite_calibrate_cmd) return maps::experiments::run_suite_calibrate(suite_calibrate);
    if (*report_cmd) return maps::experiments::run_report(report);
    if (*data_export_cmd) return maps::experiments::run_data_export(data_export);
    if (*data_import_cmd) return maps::experiments::run_data_import(data_import);
    if (*schema_cmd) return maps::experiments::run_schema(schema);
  } catch (const maps::experiments::UsageError& e) {
    std::cerr << "maps: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "maps: error: " << e.what() << "\n";
    return 1;
  }

  // No subcommand: show what there is, and fail so scripts notice.
  std::cerr << app.help();
  return 2;
}
