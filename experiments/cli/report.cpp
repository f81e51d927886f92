// `maps report`: a suite folder's results table, report and figures.

#include <memory>

#include "experiments/cli/command.h"
#include "experiments/report/report_script.h"

namespace maps::experiments::cli {

void add_report(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<ReportOptions>();
  CLI::App* command = tool.add_subcommand(
      "report", "Write a suite folder's results.csv, report.md and the paper's figures (experiments/report/report.py)");
  command->add_option("dir", options->dir, "Suite folder")->required()->check(CLI::ExistingDirectory);
  command->add_option("--out", options->out, "Report folder (default: DIR/report)");
  CLI::Option* study =
      command->add_option("--study", options->study,
                          "The study a quick-scale suite's numbers and figures are shown beside (default: the "
                          "checkout's results/study; docs/suite.md)");
  command->add_flag("--no-study", options->no_study, "Show a quick-scale suite without the study beside it")
      ->excludes(study);
  commands.push_back({command, [options] { return run_report(*options); }});
}

}  // namespace maps::experiments::cli
