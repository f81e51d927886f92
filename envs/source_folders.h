#pragma once

#include <filesystem>
#include <string>

// Folders of data that ship with the source tree (MJCF assets, committed experts), found the same way by every
// tool and test wherever it runs from.
namespace maps::envs {

// <relative> folder of the project's source tree (e.g. "envs/experts", "experiments/suites"): $<env_var> if set (it
// must then be a directory), else that folder of the source tree this library was built from, else the installed
// copy (<CMAKE_INSTALL_PREFIX>/share/maps/<relative>, for envs/assets and envs/experts), else the first <relative>
// found walking up from the working directory. Throws, listing what was tried, when none exists.
std::filesystem::path find_source_folder(const std::string& relative, const char* env_var);

// envs/<name> of the project: $<env_var> if set (it must then be a directory), else envs/<name> of the source
// tree this library was built from, else the first envs/<name> found walking up from the working directory.
// Throws, listing what was tried, when none exists.
std::filesystem::path find_envs_folder(const std::string& name, const char* env_var);

// envs/experts (override: MAPS_EXPERTS_DIR): one expert JSON per task, <set>/<task>.json.
std::filesystem::path experts_dir();
// experts_dir() / "<task>.json" for a task name such as "gravity/0.5" (the file need not exist).
std::filesystem::path expert_path(const std::string& task);

}  // namespace maps::envs
