#include "experiments/interop/data_convert.h"

#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "envs/demo_file.h"
#include "envs/source_folders.h"
#include "experiments/process/child_process.h"
#include "io/output_files.h"

namespace maps::experiments {
namespace fs = std::filesystem;

namespace {

const std::string kPython = "/usr/bin/python3";  // Debian's, with h5py (scripts/setup.sh installs python3-h5py)

int run_formats_script(const std::vector<std::string>& args) {
  const fs::path script = envs::find_source_folder("experiments/interop", "MAPS_INTEROP_DIR") / "formats.py";
  if (!fs::exists(script)) throw std::runtime_error("the conversion script " + script.string() + " is missing");
  if (!fs::exists(kPython))
    throw std::runtime_error("maps data needs " + kPython + " with h5py (bash scripts/setup.sh installs them)");
  std::vector<std::string> all{script.string()};
  all.insert(all.end(), args.begin(), args.end());
  const int code = run_program(kPython, all, nullptr);
  if (code == 127) throw std::runtime_error("cannot run " + kPython);
  // h5py shares libhdf5, which can crash on a damaged file (docs/reliability.md): a death is said, not a bare status.
  if (code > 128)
    throw std::runtime_error(script.string() + " died of signal " + std::to_string(code - 128) + " converting '" +
                             args[args.size() - 2] + "' (libhdf5 crashes on some damaged files: the input is damaged)");
  return code;
}

}  // namespace

int run_data_export(const DataConvertOptions& options) {
  const envs::DemoFile demos = envs::read_demo_file(options.input);
  if (demos.format_version < 2)
    throw std::runtime_error("'" + options.input + "' is a format " + std::to_string(demos.format_version) +
                             " demo file, which did not record next_obs and episode ends: collect it again with `" +
                             demos.creation_command + "`");
  if (options.format == "minari")
    io::check_output_folder("--out", options.out);
  else
    io::check_output_file("--out", options.out);
  std::vector<std::string> args{"export", "--format", options.format};
  if (!options.dataset_id.empty()) args.insert(args.end(), {"--dataset-id", options.dataset_id});
  args.insert(args.end(), {options.input, options.out});
  const int code = run_formats_script(args);
  if (code == 0)
    std::printf("wrote %s (%s): %zu demos, %lld samples\n", options.out.c_str(), options.format.c_str(),
                demos.demos.size(), static_cast<long long>(demos.total_samples()));
  return code;
}

int run_data_import(const DataConvertOptions& options) {
  if (fs::is_regular_file(options.out) && !options.force)
    throw std::invalid_argument("--out " + options.out + " already exists: pass --force to replace it");
  io::check_output_file("--out", options.out);
  std::vector<std::string> args{"import", "--format", options.format};
  if (!options.task_set.empty()) args.insert(args.end(), {"--task-set", options.task_set});
  if (!options.obs_keys.empty()) args.insert(args.end(), {"--obs-keys", options.obs_keys});
  args.insert(args.end(), {options.input, options.out});
  const int code = run_formats_script(args);
  if (code != 0) return code;
  try {
    const envs::DemoFile demos = envs::read_demo_file(options.out);
    std::printf("wrote %s: %zu demos of %zu tasks (%zu train, %zu valid), %lld samples\n", options.out.c_str(),
                demos.demos.size(), demos.task_names.size(), demos.train.size(), demos.valid.size(),
                static_cast<long long>(demos.total_samples()));
  } catch (const std::exception& e) {
    std::error_code ignored;
    fs::remove(options.out, ignored);
    throw std::runtime_error(std::string("the imported file did not pass this project's reader (removed): ") +
                             e.what());
  }
  return 0;
}

}  // namespace maps::experiments
