// The `maps` command-line tool: the dispatch table of its commands. Each command's options, their checks and the
// call into maps_experiments are in its own file under experiments/cli/ (docs/architecture.md).

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <string>

#include "autograd/ops.h"
#include "experiments/cli/command.h"
#include "experiments/process/command_line.h"
#include "experiments/process/usage_error.h"
#include "experiments/process/version.h"

namespace {

using namespace maps::experiments::cli;

// The commands in the order `maps --help` lists them.
constexpr AddCommand* kCommands[] = {add_demo,   add_train_expert, add_collect, add_render, add_expert_eval,
                                     add_train,  add_transfer,     add_eval,    add_bench,  add_suite,
                                     add_report, add_data,         add_schema};

// The version, the commit and what the build computes with: what a bug report or a speed figure needs.
std::string version_text() {
  std::string kernel;
  try {
    kernel = maps::ag::float32_gemm_kernel();
  } catch (const std::exception& e) {  // MAPS_F32_KERNEL names none this CPU runs
    kernel = std::string("(none: ") + e.what() + ")";
  }
  return std::string("maps ") + maps::experiments::tool_version() + "\ncommit " + maps::experiments::tool_git_commit() +
         "\nbuild " + maps::experiments::tool_build() + "\nfloat32 GEMM kernel " + kernel;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App tool{"maps: multi-task imitation learning on a from-scratch autograd engine"};
  tool.name("maps");
  tool.set_version_flag("--version", version_text);
  tool.require_subcommand(0, 1);
  Commands commands;
  for (const auto add : kCommands) add(tool, commands);

  // Exit codes (docs/cli.md): 0 done, 1 the work failed (bad input files, a failed run), 2 the command line is wrong
  // (CLI11's own codes, 105-109 by kind, are folded into 2), 3 `suite run` left cells to another process.
  try {
    tool.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return tool.exit(e) == 0 ? 0 : 2;  // --help is a ParseError that exits 0
  }
  maps::experiments::set_command_line(argc, argv);
  try {
    for (const auto& command : commands)
      if (*command.app) return command.run();
  } catch (const maps::experiments::UsageError& e) {
    std::cerr << "maps: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "maps: error: " << e.what() << "\n";
    return 1;
  }
  // No subcommand: show what there is, and fail so scripts notice.
  std::cerr << tool.help();
  return 2;
}
