// `maps report`: experiments/report/report.py run on Debian's python3.

#include "experiments/report/report_script.h"

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "envs/source_folders.h"
#include "experiments/process/child_process.h"
#include "experiments/run/run_folder.h"
#include "experiments/suite/folder.h"
#include "experiments/suite/status.h"
#include "io/output_files.h"

namespace maps::experiments {

namespace fs = std::filesystem;

int run_report(const ReportOptions& options) {
  const fs::path script = envs::find_source_folder("experiments/report", "MAPS_REPORT_DIR") / "report.py";
  if (!fs::exists(script)) throw std::runtime_error("the report script " + script.string() + " is missing");
  if (!fs::exists(fs::path(options.dir) / suite_files::kManifest))
    throw std::runtime_error(options.dir + " is not a suite folder: it has no suite.json (maps suite run writes it)");
  const std::string out = options.out.empty() ? (fs::path(options.dir) / "report").string() : options.out;
  io::check_output_folder("--out", out);
  const std::string python = "/usr/bin/python3";  // Debian's, with matplotlib (scripts/setup.sh)
  if (!fs::exists(python))
    throw std::runtime_error("maps report needs " + python + " with matplotlib (bash scripts/setup.sh installs it)");
  // What each cell is, decided here and nowhere else (experiments/suite/status.h): the report reads it, and keeps it
  // beside itself as the state of the folder it was made from.
  const std::string status = (fs::path(out) / "status.json").string();
  write_json_file(status, suite_status({options.dir}));
  std::vector<std::string> arguments{script.string(), options.dir, out, "--status", status};
  if (options.no_study) arguments.push_back("--no-study");
  if (!options.study.empty()) arguments.insert(arguments.end(), {"--study", options.study});
  // The study's cells are read through a tool too (its status): this one, whichever folder it was built in.
  std::error_code error;
  if (std::getenv("MAPS_TOOL") == nullptr)
    if (const fs::path self = fs::canonical("/proc/self/exe", error); !error) setenv("MAPS_TOOL", self.c_str(), 0);
  const int code = run_program(python, arguments, nullptr);
  if (code == 127) throw std::runtime_error("cannot run " + python);
  return code;
}

}  // namespace maps::experiments
