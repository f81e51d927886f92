#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

// The option checks and the options every command declares alike, written once.
namespace maps::experiments::cli {

// Sign checks with short messages ("--steps: must be a finite number > 0, got '-3'"). CLI11's PositiveNumber prints
// DBL_MAX in full, and CLI11 2.1 turns "-1" into 2^64-1 for an unsigned option without a check. Infinities and
// NaN are refused too: "--seconds inf" ran `bench step` forever, "--lr inf" trained to NaN.
CLI::Validator positive();
CLI::Validator non_negative();
// Seeds are 64-bit unsigned; CLI11 2.1 saturates a larger number to 2^64-1 without a word.
CLI::Validator seed_value();
// A 64-bit integer option: CLI11 2.1 saturates a number past int64's range instead of refusing it.
CLI::Validator integer_in(std::int64_t low, std::int64_t high);
// CLI::Range lets NaN through (every comparison with it is false).
CLI::Validator number_in(double low, double high);
// One of envs::task_set_names().
CLI::Validator task_set_name();
// A thread count: 0 means one per core (at most ag::kMaxThreads); a larger count is refused (a billion threads ended
// in std::terminate).
CLI::Validator thread_count();

// --threads, checked by thread_count(), shown with its default.
CLI::Option* add_threads(CLI::App* command, int& threads, const std::string& description);
// Cells at once are processes, each with its own threads: a cluster node or a plan may count far more of them.
CLI::Option* add_jobs(CLI::App* command, int& jobs, const std::string& description);
CLI::Option* add_seed(CLI::App* command, std::uint64_t& seed, const std::string& description);
// --set NAME for a task set ("Task set: gravity, modified or mt10").
// `plugins` (collect's --plugin values): when any is given, a set name is checked by the command once they are
// loaded, not by the command line.
CLI::Option* add_task_set(CLI::App* command, std::string& set, const std::vector<std::string>* plugins = nullptr);
// An option whose value must be > 0 (or >= 0), shown with its default.
template <typename T>
CLI::Option* add_positive(CLI::App* command, const std::string& name, T& value, const std::string& description) {
  return command->add_option(name, value, description)->check(positive())->capture_default_str();
}
template <typename T>
CLI::Option* add_non_negative(CLI::App* command, const std::string& name, T& value, const std::string& description) {
  return command->add_option(name, value, description)->check(non_negative())->capture_default_str();
}

// An integer option in [low, high], shown with its default.
template <typename T>
CLI::Option* add_integer(CLI::App* command, const std::string& name, T& value, std::int64_t low, std::int64_t high,
                         const std::string& description) {
  return command->add_option(name, value, description)->check(integer_in(low, high))->capture_default_str();
}

// The thread count a command computes with: `threads`, or one per core (at most ag::kMaxThreads) when it is 0.
int threads_or_cores(int threads);

}  // namespace maps::experiments::cli
