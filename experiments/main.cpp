// The `maps` command-line tool. Each subcommand parses its options here and dispatches to a
// function declared in its own header under experiments/.

#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>
#include <string>

#include "experiments/demo.h"
#include "experiments/train_expert.h"

namespace {

// Sign checks with short messages ("--steps: must be a number > 0, got '-3'"). CLI11's PositiveNumber prints
// DBL_MAX in full, and CLI11 2.1 turns "-1" into 2^64-1 for an unsigned option without a check.
CLI::Validator sign_check(bool allow_zero) {
  return CLI::Validator(
      [allow_zero](std::string& input) -> std::string {
        double value = 0.0;
        if (CLI::detail::lexical_cast(input, value) && (value > 0.0 || (allow_zero && value == 0.0))) return {};
        return std::string(allow_zero ? "must be a number >= 0" : "must be a number > 0") + ", got '" + input + "'";
      },
      allow_zero ? "NONNEGATIVE" : "POSITIVE");
}

}  // namespace

int main(int argc, char** argv) {
  const CLI::Validator positive = sign_check(false);
  const CLI::Validator non_negative = sign_check(true);

  CLI::App app{"maps: multi-task imitation learning on a from-scratch autograd engine"};
  app.name("maps");
  app.require_subcommand(0, 1);

  maps::experiments::DemoOptions demo;
  CLI::App* demo_cmd =
      app.add_subcommand("demo", "Train a small tanh MLP on a synthetic regression and print the loss falling");
  demo_cmd->add_option("--steps", demo.steps, "Optimiser steps")->check(positive)->capture_default_str();
  demo_cmd->add_option("--seed", demo.seed, "Seed of the data and the initial weights")
      ->check(non_negative)
      ->capture_default_str();
  demo_cmd->add_option("--hidden", demo.hidden, "Hidden width")->check(positive)->capture_default_str();
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
      ->check(positive)
      ->capture_default_str();
  train_expert_cmd->add_option("--seed", train_expert.seed, "Seed")->check(non_negative)->capture_default_str();
  train_expert_cmd->add_option("--checkpoint-every", train_expert.checkpoint_every, "Iterations between checkpoints")
      ->check(positive)
      ->capture_default_str();
  train_expert_cmd->add_option("--eval-episodes", train_expert.eval_episodes, "Deterministic episodes at the end")
      ->check(positive)
      ->capture_default_str();
  train_expert_cmd->add_option("--init", train_expert.init,
                               "Warm start from another run's checkpoint.ckpt (when DIR has none)");
  train_expert_cmd
      ->add_option("--abandon-flipped", train_expert.abandon_flipped,
                   "Past this many steps, stop (exit 3) once the last 5 rollouts ran on the back; 0: never")
      ->check(non_negative)
      ->capture_default_str();

  CLI11_PARSE(app, argc, argv);

  try {
    if (*demo_cmd) return maps::experiments::run_demo(demo);
    if (*train_expert_cmd) return maps::experiments::run_train_expert(train_expert);
  } catch (const std::exception& e) {
    std::cerr << "maps: error: " << e.what() << "\n";
    return 1;
  }

  // No subcommand: show what there is, and fail so scripts notice.
  std::cerr << app.help();
  return 2;
}
