#include "experiments/suite/demo_files.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "envs/demo_file.h"
#include "experiments/process/child_process.h"
#include "experiments/process/host.h"

namespace maps::experiments {

namespace fs = std::filesystem;

void ensure_demo_files(const Suite& suite, const std::vector<const SuiteCell*>& cells, int threads) {
  std::set<std::string> sets;
  for (const auto* cell : cells) sets.insert(cell->set);
  for (const auto& name : sets) {
    const SuiteSet& set = suite.sets.at(name);
    const fs::path file(set.demo_file);
    if (fs::exists(file)) {
      const envs::DemoFile demos = envs::read_demo_file(file.string());
      if (demos.task_set != name)
        throw std::runtime_error(file.string() + " holds task set '" + demos.task_set + "', but the suite's set '" +
                                 name + "' names it (sets." + name + ".data.file)");
      continue;
    }
    if (!file.parent_path().empty()) fs::create_directories(file.parent_path());
    const fs::path partial = file.string() + "." + host_name() + "." + std::to_string(::getpid()) + ".partial.h5";
    const fs::path log = file.string() + ".collect.log";
    std::printf("suite: collecting %s (%s, %d demos per task; log %s)\n", file.string().c_str(), name.c_str(),
                set.collect_demos, log.string().c_str());
    std::fflush(stdout);
    const auto start = std::chrono::steady_clock::now();
    std::vector<std::string> arguments{"collect",
                                       "--set",
                                       name,
                                       "--demos",
                                       std::to_string(set.collect_demos),
                                       "--out",
                                       partial.string(),
                                       "--threads",
                                       std::to_string(threads)};
    for (const auto& plugin : suite.source.value("plugins", nlohmann::json::array()))  // a plugin's set
      arguments.insert(arguments.end(), {"--plugin", plugin.get<std::string>()});
    const int code = run_self(arguments, log);
    if (code != 0) {
      fs::remove(partial);
      throw std::runtime_error("collecting " + file.string() + " failed (exit " + std::to_string(code) +
                               "): " + last_line(log));
    }
    fs::rename(partial, file);
    std::printf("suite: wrote %s in %.0f s\n", file.string().c_str(), seconds_since(start));
    std::fflush(stdout);
  }
}

int run_suite_prepare(const std::string& config_path, int threads) {
  const Suite suite = load_suite(config_path);
  std::vector<const SuiteCell*> all;
  for (const auto& cell : suite.cells) all.push_back(&cell);
  ensure_demo_files(suite, all, threads);
  std::printf("suite: the demonstration files of %s are in place\n", config_path.c_str());
  return 0;
}

}  // namespace maps::experiments
