#include "envs/source_folders.h"

#include <cstdlib>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace maps::envs {

std::filesystem::path find_source_folder(const std::string& relative, const char* env_var) {
  namespace fs = std::filesystem;
  if (const char* from_env = std::getenv(env_var); from_env != nullptr && *from_env != '\0') {
    const fs::path dir(from_env);
    if (!fs::is_directory(dir)) {
      throw std::runtime_error(std::string(env_var) + " is set to '" + dir.string() + "', which is not a directory");
    }
    return dir;
  }
  std::vector<fs::path> tried;
  // The source tree this file (envs/source_folders.cpp) was compiled from (CMake passes absolute source paths).
  const fs::path from_source = fs::path(__FILE__).parent_path().parent_path() / relative;
  tried.push_back(from_source);
  if (from_source.is_absolute() && fs::is_directory(from_source)) return from_source;
#ifdef MAPS_INSTALL_DATADIR
  // Where `cmake --install` puts envs/assets and envs/experts (the prefix configured at build time).
  const fs::path installed = fs::path(MAPS_INSTALL_DATADIR) / relative;
  tried.push_back(installed);
  if (fs::is_directory(installed)) return installed;
#endif
  // Walking up from the working directory, for a copied tree or a relocated build.
  std::error_code ec;
  for (fs::path dir = fs::current_path(ec); !ec && !dir.empty(); dir = dir.parent_path()) {
    const fs::path candidate = dir / relative;
    tried.push_back(candidate);
    if (fs::is_directory(candidate)) return candidate;
    if (dir == dir.root_path()) break;
  }
  std::string message = "cannot find the folder " + relative + " of the source tree; set " + env_var + ". Tried:";
  for (const auto& path : tried) message += " '" + path.string() + "'";
  throw std::runtime_error(message);
}

std::filesystem::path find_envs_folder(const std::string& name, const char* env_var) {
  return find_source_folder("envs/" + name, env_var);
}

std::filesystem::path experts_dir() { return find_envs_folder("experts", "MAPS_EXPERTS_DIR"); }

std::filesystem::path expert_path(const std::string& task) { return experts_dir() / (task + ".json"); }

}  // namespace maps::envs
