#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

// C++ plugins (maps/plugin.h): shared libraries a run or suite config names under "plugins", loaded into this
// process before the config is read so the selector losses and methods they register are known by name. A plugin is
// loaded once per process, however many configs name it, and stays loaded (its code is behind registry entries).
namespace maps::experiments {

struct LoadedPlugin {
  std::string path;                     // absolute, as loaded
  std::string sha256;                   // of the file when it was loaded
  std::string version;                  // the library version it was built against (its MAPS_PLUGIN() mark)
  std::vector<std::string> registered;  // what it added: "selector loss task_entropy", "method tiny_mlp"
};

// Loads the plugin at `path` (absolute, or relative to the working directory) unless it is loaded already: a shared
// library, or a Python file (.py, run by the tool's embedded interpreter: set_python_plugin_runner). Refused
// with std::invalid_argument naming `named_by` and the file: a missing or unreadable file, a library without a
// MAPS_PLUGIN() mark, one built against another library version (both named; checked before any of its code runs),
// one the dynamic loader refuses (its message: a missing symbol, another architecture), and one whose registrations
// are refused (a name a built-in or another plugin has, a name that is not plain).
const LoadedPlugin& load_plugin(const std::string& path, const std::string& named_by);

// Every plugin loaded in this process, in load order (provenance records them), with the Python code registered
// through record_external_code.
std::vector<LoadedPlugin> loaded_plugins();

// Records code from outside the tree that registered entries some other way (a Python class registered by
// maps.register_selector_loss: its source file, digest and what it registered), so provenance names it too. Entries
// for the same path are merged.
void record_external_code(const LoadedPlugin& code);

// A Python plugin (a config's "plugins" entry ending in .py) is run by the embedded interpreter of a tool built with
// Python (python/embed.cpp installs this hook); it runs the file, whose code registers its selector losses and
// methods, and throws with Python's message when the file fails. Without the hook a .py plugin is refused.
using PythonPluginRunner = void (*)(const std::string& path);
void set_python_plugin_runner(PythonPluginRunner runner);

// The config's "plugins" (a list of paths; none when the key is absent) checked and made absolute, relative paths
// taken from `base_folder` (the config file's folder), then loaded. Returns the config with those absolute paths,
// which is what a run folder's config.json records (it is read from elsewhere than the config it came from).
// `where` names the config in errors ("--config 'a.json'").
nlohmann::json load_config_plugins(nlohmann::json config, const std::string& base_folder, const std::string& where);

// The folder a config file's relative plugin paths are taken from.
std::string folder_of(const std::string& config_path);

}  // namespace maps::experiments
