// `maps suite plan|run|prepare|status|merge|calibrate`: the comparison suite.

#include <memory>
#include <string>

#include "experiments/cli/command.h"
#include "experiments/cli/options.h"
#include "experiments/suite/calibrate.h"
#include "experiments/suite/demo_files.h"
#include "experiments/suite/merge.h"
#include "experiments/suite/plan.h"
#include "experiments/suite/run.h"
#include "experiments/suite/status.h"

namespace maps::experiments::cli {
namespace {

CLI::Option* add_config(CLI::App* command, std::string& path) {
  return command->add_option("config", path, "Suite config (JSON)")->required()->check(CLI::ExistingFile);
}

CLI::Option* add_precision(CLI::App* command, std::string& precision) {
  return command
      ->add_option("--precision", precision,
                   "Every cell's train.precision (float32, or bf16 on CPUs with AVX512-BF16), unless its set or "
                   "variant sets it")
      ->check(CLI::IsMember({"float32", "bf16"}));
}

void add_plan(CLI::App* suite, Commands& commands) {
  auto options = std::make_shared<SuitePlanOptions>();
  CLI::App* command = suite->add_subcommand("plan", "Print a suite's cells, their count and the estimated CPU time");
  add_config(command, options->config_path);
  command
      ->add_option("--shard", options->shard,
                   "Only the cells with index % N == i (a transfer cell: its source's index)")
      ->capture_default_str();
  add_jobs(command, options->jobs, "Cells at once, for the wall-time estimate (0: cores)");
  command->add_flag("--cells", options->list_cells, "List every cell");
  command->add_flag("--json", options->json, "Print one JSON object (every cell and the estimate)");
  command->add_option("--costs", options->costs, "Cost table (default: experiments/suites/costs.json)");
  add_precision(command, options->precision);
  commands.push_back({command, [options] { return run_suite_plan(*options); }});
}

void add_run(CLI::App* suite, Commands& commands) {
  auto options = std::make_shared<SuiteRunOptions>();
  CLI::App* command = suite->add_subcommand(
      "run", "Run a suite's cells (resumable: finished cells are skipped, unfinished ones resume)");
  add_config(command, options->config_path);
  command->add_option("--out", options->out, "Suite folder")->required();
  add_jobs(command, options->jobs, "Cells at once (0: cores / threads)")->capture_default_str();
  add_threads(command, options->threads, "Op threads per cell (0: one per core)");
  command
      ->add_option("--shard", options->shard,
                   "Run only the cells with index % N == i (i/N; a transfer cell: its source's index)")
      ->capture_default_str();
  command->add_option("--costs", options->costs, "Cost table for the ETA");
  add_precision(command, options->precision);
  commands.push_back({command, [options] {
                        options->threads = threads_or_cores(options->threads);
                        return run_suite(*options);
                      }});
}

void add_prepare(CLI::App* suite, Commands& commands) {
  auto config = std::make_shared<std::string>();
  auto threads = std::make_shared<int>(0);
  CLI::App* command =
      suite->add_subcommand("prepare", "Collect the suite's missing demonstration files (before a cluster run)");
  add_config(command, *config);
  command->add_option("--threads", *threads, "Tasks rolled out at once (0: one per core)")->check(thread_count());
  commands.push_back({command, [config, threads] { return run_suite_prepare(*config, *threads); }});
}

void add_status(CLI::App* suite, Commands& commands) {
  auto options = std::make_shared<SuiteStatusOptions>();
  CLI::App* command =
      suite->add_subcommand("status", "Say which cells of a suite folder are done, running, failed or left");
  command->add_option("dirs", options->dirs, "Suite folder, or the shard folders of one suite")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_flag("--all", options->all, "One line per cell");
  command->add_flag("--json", options->json, "Print one JSON object");
  commands.push_back({command, [options] { return run_suite_status(*options); }});
}

void add_merge(CLI::App* suite, Commands& commands) {
  auto options = std::make_shared<SuiteMergeOptions>();
  CLI::App* command =
      suite->add_subcommand("merge", "Copy the finished cells of shard folders of one suite into one folder");
  command->add_option("--out", options->out, "Merged suite folder")->required();
  command->add_option("shards", options->shards, "Shard folders")->required()->check(CLI::ExistingDirectory);
  commands.push_back({command, [options] { return run_suite_merge(*options); }});
}

void add_calibrate(CLI::App* suite, Commands& commands) {
  auto options = std::make_shared<SuiteCalibrateOptions>();
  CLI::App* command = suite->add_subcommand(
      "calibrate", "Time a short run of every method on every set and write the cost table plan and run use");
  command->add_option("--out", options->out, "Cost table (default: experiments/suites/costs.json)");
  command->add_option("--work", options->work, "Folder for the timed runs")->capture_default_str();
  add_positive(command, "--steps", options->steps, "Training steps per timed run");
  add_positive(command, "--episodes", options->episodes, "Evaluation episodes per task");
  command->add_option("--sets", options->sets, "Task sets to time")->check(task_set_name());
  command->add_option("--methods", options->methods,
                      "Methods to time (default: every registered one); the table keeps the others' entries");
  command
      ->add_option("--suite", options->suite,
                   "Suite whose per-set settings are timed (default: experiments/suites/paper.json)")
      ->check(CLI::ExistingFile);
  command
      ->add_option("--gail-env-steps", options->gail_env_steps,
                   "Also time each method that trains by GAIL (not maml, not action chunks) for this many env steps "
                   "per task (0: not)")
      ->check(CLI::Range(std::int64_t{0}, std::int64_t{100'000'000}));
  commands.push_back({command, [options] { return run_suite_calibrate(*options); }});
}

}  // namespace

void add_suite(CLI::App& tool, Commands& commands) {
  CLI::App* suite = tool.add_subcommand(
      "suite", "The comparison suite: a grid of train + eval cells from a suite config (experiments/suites/*.json)");
  suite->require_subcommand(1);
  add_plan(suite, commands);
  add_run(suite, commands);
  add_prepare(suite, commands);
  add_status(suite, commands);
  add_merge(suite, commands);
  add_calibrate(suite, commands);
}

}  // namespace maps::experiments::cli
