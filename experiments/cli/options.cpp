#include "experiments/cli/options.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>
#include <thread>

#include "autograd/parallel.h"
#include "envs/task_sets.h"

namespace maps::experiments::cli {
namespace {

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

std::string number_text(double x) {
  std::ostringstream out;
  out << x;
  return out.str();
}

}  // namespace

CLI::Validator positive() { return sign_check(false); }
CLI::Validator non_negative() { return sign_check(true); }

CLI::Validator seed_value() {
  return CLI::Validator(
      [](std::string& input) -> std::string {
        std::uint64_t value = 0;
        const auto [end, error] = std::from_chars(input.data(), input.data() + input.size(), value);
        if (!input.empty() && error == std::errc() && end == input.data() + input.size()) return {};
        return "must be an integer in [0, 18446744073709551615], got '" + input + "'";
      },
      "UINT64");
}

CLI::Validator integer_in(std::int64_t low, std::int64_t high) {
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

CLI::Validator number_in(double low, double high) {
  return CLI::Validator(
      [low, high](std::string& input) -> std::string {
        double value = 0.0;
        if (CLI::detail::lexical_cast(input, value) && value >= low && value <= high) return {};
        return "must be a number in [" + number_text(low) + ", " + number_text(high) + "], got '" + input + "'";
      },
      "FLOAT in [" + number_text(low) + " - " + number_text(high) + "]");
}

CLI::Validator task_set_name() { return CLI::IsMember(envs::task_set_names()); }

CLI::Validator thread_count() { return integer_in(0, ag::kMaxThreads); }

CLI::Option* add_threads(CLI::App* command, int& threads, const std::string& description) {
  return command->add_option("--threads", threads, description)->check(thread_count())->capture_default_str();
}

CLI::Option* add_jobs(CLI::App* command, int& jobs, const std::string& description) {
  return command->add_option("--jobs", jobs, description)->check(integer_in(0, 65536));
}

CLI::Option* add_seed(CLI::App* command, std::uint64_t& seed, const std::string& description) {
  return command->add_option("--seed", seed, description)->check(seed_value())->capture_default_str();
}

CLI::Option* add_task_set(CLI::App* command, std::string& set, const std::vector<std::string>* plugins) {
  std::string names;
  const auto all = envs::task_set_names();
  for (std::size_t i = 0; i < all.size(); ++i) names += (i == 0 ? "" : i + 1 == all.size() ? " or " : ", ") + all[i];
  CLI::Option* option = command->add_option("--set", set, "Task set: " + names + (plugins ? ", or a plugin's" : ""));
  if (plugins == nullptr) return option->check(task_set_name());
  // A plugin's set is known once the plugin is loaded, which the command does first: checked there.
  const CLI::Validator built_in = task_set_name();
  return option->check(CLI::Validator(
      [plugins, built_in](std::string& input) { return plugins->empty() ? built_in(input) : std::string(); },
      built_in.get_description()));
}

int threads_or_cores(int threads) {
  if (threads != 0) return threads;
  return std::min(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())), ag::kMaxThreads);
}

}  // namespace maps::experiments::cli
