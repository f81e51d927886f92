#include "experiments/process/plugins.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <stdexcept>

#include "envs/task_sets.h"
#include "experiments/process/file_digest.h"
#include "io/registry.h"
#include "io/version.h"
#include "maps/plugin.h"
#include "maps/policies/policy_registry.h"
#include "maps/selector/selector_loss.h"

namespace maps::experiments {
namespace {

namespace fs = std::filesystem;

// A plugin is a few megabytes; a file far larger is not one (and is not read whole to find out).
constexpr std::uintmax_t kMaxPluginBytes = std::uintmax_t{1} << 30;

std::mutex& plugins_mutex() {
  static std::mutex mutex;
  return mutex;
}
// A deque: load_plugin hands out references that stay valid as plugins are added.
std::deque<LoadedPlugin>& plugins() {
  static std::deque<LoadedPlugin> loaded;
  return loaded;
}

// The version in the file's MAPS_PLUGIN() mark, "" when it has none. Read from the bytes, so a plugin built against
// another version is refused before its static initialisers (its registrations) run in this process.
std::string marked_version(const std::string& path, const std::string& where) {
  std::error_code error;
  const std::uintmax_t size = fs::file_size(path, error);
  if (error) throw std::invalid_argument(where + ": cannot read plugin '" + path + "': " + error.message());
  if (size > kMaxPluginBytes)
    throw std::invalid_argument(where + ": '" + path + "' is " + std::to_string(size >> 20) +
                                " MiB, too large to be a maps plugin (at most 1 GiB)");
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.eof() && in.fail()) throw std::invalid_argument(where + ": cannot read plugin '" + path + "'");
  const std::string prefix = MAPS_PLUGIN_MARK_PREFIX;
  const std::size_t at = bytes.find(prefix);
  if (at == std::string::npos) return "";
  std::string version;
  for (std::size_t i = at + prefix.size(); i < bytes.size() && bytes[i] != '\0' && version.size() <= 32; ++i) {
    const char c = bytes[i];
    const bool plain =
        (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '.' || c == '-' || c == '+';
    if (!plain) return "";
    version += c;
  }
  return version.size() <= 32 ? version : "";
}

PythonPluginRunner& python_runner() {
  static PythonPluginRunner runner = nullptr;
  return runner;
}

std::vector<std::string> registered_names() {
  std::vector<std::string> names;
  for (const auto& loss : core::selector_losses()) names.push_back("selector loss " + loss.name);
  for (const auto& method : core::policy_methods()) names.push_back("method " + method.name);
  for (const auto& set : envs::task_set_names()) names.push_back("task set " + set);
  return names;
}

// The plugin recorded with what it registered (every name not among `before`), as the loaded plugins' last.
const LoadedPlugin& record_loaded(LoadedPlugin plugin, const std::vector<std::string>& before) {
  for (const std::string& name : registered_names())
    if (std::find(before.begin(), before.end(), name) == before.end()) plugin.registered.push_back(name);
  plugins().push_back(std::move(plugin));
  return plugins().back();
}

std::string joined(const std::vector<std::string>& parts, const char* separator) {
  std::string out;
  for (const std::string& part : parts) out += (out.empty() ? "" : separator) + part;
  return out;
}

}  // namespace

const LoadedPlugin& load_plugin(const std::string& given_path, const std::string& named_by) {
  std::lock_guard<std::mutex> lock(plugins_mutex());
  const std::string where = named_by + ": plugin '" + given_path + "'";
  std::error_code error;
  if (!fs::exists(given_path, error))
    throw std::invalid_argument(where +
                                " does not exist (a shared library built with MAPS_PLUGIN(); "
                                "docs/extending.md)");
  if (!fs::is_regular_file(given_path, error))
    throw std::invalid_argument(where + " is not a file (a shared library built with MAPS_PLUGIN())");
  const std::string path = fs::weakly_canonical(fs::absolute(given_path)).string();
  for (const LoadedPlugin& plugin : plugins())
    if (plugin.path == path) return plugin;

  const std::vector<std::string> before = registered_names();
  if (path.ends_with(".py")) {
    if (python_runner() == nullptr)
      throw std::invalid_argument(where +
                                  " is a Python plugin, and this maps tool was built without Python "
                                  "(pybind11-dev and python3-dev at configure time; docs/extending.md)");
    const std::string sha256 = sha256_of_file(path);
    {
      const io::LoadingOrigin origin(path);
      try {
        python_runner()(path);
      } catch (const std::exception& e) {
        throw std::invalid_argument(where + " failed: " + e.what());
      }
    }
    return record_loaded({path, sha256, "python", {}}, before);
  }
  const std::string version = marked_version(path, named_by);
  if (version.empty())
    throw std::invalid_argument(where +
                                " is not a maps plugin: it has no MAPS_PLUGIN() mark (maps/plugin.h: one "
                                ".cpp of the plugin says MAPS_PLUGIN();), so it was not loaded");
  if (version != MAPS_VERSION)
    throw std::invalid_argument(where + " was built against maps " + version + ", and this is maps " + MAPS_VERSION +
                                ": rebuild it against this version (find_package(maps " + MAPS_VERSION + "))");
  const std::string sha256 = sha256_of_file(path);

  std::vector<std::string> program_errors = io::take_registration_errors();
  void* handle = nullptr;
  {
    const io::LoadingOrigin origin(path);
    handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  }
  std::vector<std::string> refused = io::take_registration_errors();
  if (!program_errors.empty()) {  // the program's own, kept for the registries' first use to report
    std::lock_guard<std::mutex> errors_lock(io::registration_errors_mutex());
    auto& errors = io::registration_errors();
    errors.insert(errors.begin(), program_errors.begin(), program_errors.end());
  }
  if (handle == nullptr) {
    const char* message = dlerror();
    throw std::invalid_argument(where + " could not be loaded: " + (message ? message : "unknown error") +
                                " (a plugin links maps::plugin, not the maps libraries, and is built for this "
                                "machine's architecture; C++ plugins are loaded by the maps tool, and from Python "
                                "a config names Python files instead; docs/extending.md)");
  }
  // The handle is never closed: the registries hold the plugin's factories.
  const auto* mark = static_cast<const char*>(dlsym(handle, "maps_plugin_mark"));
  if (mark == nullptr || std::string(mark) != std::string(MAPS_PLUGIN_MARK_PREFIX) + MAPS_VERSION)
    throw std::invalid_argument(where +
                                " holds the text of a MAPS_PLUGIN() mark but not the mark itself "
                                "(maps_plugin_mark): not a maps plugin");
  if (!refused.empty())
    throw std::invalid_argument(where + ": its registrations were refused: " + joined(refused, "; "));

  return record_loaded({path, sha256, version, {}}, before);
}

void set_python_plugin_runner(PythonPluginRunner runner) { python_runner() = runner; }

void record_external_code(const LoadedPlugin& code) {
  std::lock_guard<std::mutex> lock(plugins_mutex());
  for (LoadedPlugin& plugin : plugins())
    if (plugin.path == code.path) {
      for (const std::string& name : code.registered)
        if (std::find(plugin.registered.begin(), plugin.registered.end(), name) == plugin.registered.end())
          plugin.registered.push_back(name);
      plugin.sha256 = code.sha256;
      return;
    }
  plugins().push_back(code);
}

std::vector<LoadedPlugin> loaded_plugins() {
  std::lock_guard<std::mutex> lock(plugins_mutex());
  return {plugins().begin(), plugins().end()};
}

std::string folder_of(const std::string& config_path) {
  const fs::path folder = fs::path(config_path).parent_path();
  return folder.empty() ? "." : folder.string();
}

nlohmann::json load_config_plugins(nlohmann::json config, const std::string& base_folder, const std::string& where) {
  if (!config.is_object() || !config.contains("plugins")) return config;
  nlohmann::json& listed = config["plugins"];
  if (!listed.is_array())
    throw std::invalid_argument(where + ": config plugins: expected a list of paths to shared libraries, got " +
                                listed.dump());
  for (nlohmann::json& entry : listed) {
    if (!entry.is_string() || entry.get<std::string>().empty())
      throw std::invalid_argument(where + ": config plugins: expected a list of paths to shared libraries, got " +
                                  entry.dump() + " in it");
    const fs::path given(entry.get<std::string>());
    const std::string path = (given.is_absolute() ? given : fs::path(base_folder) / given).lexically_normal().string();
    entry = load_plugin(path, where + " (config plugins)").path;
  }
  return config;
}

}  // namespace maps::experiments
