#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

// How a command's file plugs into main.cpp's dispatch table: each file adds its subcommand (its options and their
// checks) to the tool and says what to call once the command line named it.
namespace maps::experiments::cli {

struct Command {
  const CLI::App* app = nullptr;  // the subcommand; it was chosen when *app is true after parsing
  std::function<int()> run;       // the call into the library, with the options as parsed
};
using Commands = std::vector<Command>;

// Each file of cli/ defines one: it adds its command to the tool. main.cpp's kCommands lists them in the order
// `maps --help` shows.
using AddCommand = void(CLI::App& tool, Commands& commands);
AddCommand add_demo, add_train_expert, add_collect, add_render, add_expert_eval, add_train, add_transfer, add_eval,
    add_bench, add_suite, add_report, add_data, add_schema;

}  // namespace maps::experiments::cli
