// The `maps` tool's embedded Python: a config's Python plugin ("plugins": ["losses.py"]) runs in an interpreter inside
// the tool, against the tool's own registries. The package's Python files come from beside the tool (the build's
// python/ or the install's lib/python3/dist-packages/), its C++ part (`maps._maps`) from the tool itself, so the
// classes a plugin registers are called by the same trainer `maps train` runs.

#include <pybind11/embed.h>

#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>

#include "experiments/process/plugins.h"
#include "python/bindings.h"

namespace py = pybind11;

// Named as the extension is, so that its submodules are maps._maps.nn and maps._maps.optim (def_submodule names them
// after their parent) where the package's Python files import them.
PYBIND11_EMBEDDED_MODULE(_maps_in_tool, m) {
  m.attr("__name__") = "maps._maps";
  maps::python::bind_all(m);
}

namespace maps::python {
namespace {

namespace fs = std::filesystem;

// The folder holding the package's Python files (maps/__init__.py): $MAPS_PYTHON_DIR, else beside the tool.
std::string package_folder() {
  if (const char* given = std::getenv("MAPS_PYTHON_DIR"); given != nullptr && *given != '\0') return given;
  std::error_code error;
  const fs::path tool = fs::canonical("/proc/self/exe", error);
  if (!error)
    for (const fs::path& candidate : {tool.parent_path().parent_path() / "python",
                                      tool.parent_path().parent_path() / "lib" / "python3" / "dist-packages"})
      if (fs::exists(candidate / "maps" / "__init__.py")) return candidate.string();
  throw std::runtime_error(
      "the maps Python package is not beside this tool (looked in ../python and "
      "../lib/python3/dist-packages from " +
      (error ? std::string("the tool") : fs::canonical("/proc/self/exe").string()) +
      "); set MAPS_PYTHON_DIR to the folder holding maps/__init__.py");
}

// Starts the interpreter once, with `maps._maps` being this tool's module, then hands the GIL back: the trainer's
// calls into Python take it when they need it.
void start_interpreter() {
  static std::once_flag once;
  std::call_once(once, [] {
    const std::string folder = package_folder();
    py::initialize_interpreter();
    {
      py::module_ sys = py::module_::import("sys");
      sys.attr("path").attr("insert")(0, folder);
      sys.attr("modules")["maps._maps"] = py::module_::import("_maps_in_tool");
      py::module_::import("maps");
    }
    PyEval_SaveThread();  // never taken back: the interpreter lives as long as the tool
  });
}

void run_python_plugin(const std::string& path) {
  start_interpreter();
  run_python_plugin_file(path);
}

[[maybe_unused]] const bool installed = (experiments::set_python_plugin_runner(&run_python_plugin), true);

}  // namespace
}  // namespace maps::python
