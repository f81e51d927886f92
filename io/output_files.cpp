#include "io/output_files.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>

namespace maps::io {
namespace fs = std::filesystem;

namespace {

void check_writable_folder(const std::string& option, const std::string& named, const fs::path& dir) {
  const std::string where = option + " '" + named + "': ";
  std::error_code error;
  if (fs::exists(dir, error) && !fs::is_directory(dir, error))
    throw std::runtime_error(where + "'" + dir.string() + "' is not a folder");
  fs::create_directories(dir, error);
  if (error)
    throw std::runtime_error(where + "cannot make the folder '" + dir.string() + "' (" + error.message() + ")");
  // Named as a temporary: a process killed between writing and removing it leaves it behind like any other.
  const fs::path probe = dir / (".maps-write-probe.tmp-" + std::to_string(::getpid()));
  {
    std::ofstream out(probe);
    if (!out) throw std::runtime_error(where + "cannot write in the folder '" + dir.string() + "'");
  }
  fs::remove(probe, error);
}

}  // namespace

void check_output_file(const std::string& option, const std::string& path) {
  if (path.empty()) throw std::runtime_error(option + ": expected a file name, got an empty one");
  const fs::path file(path);
  std::error_code error;
  if (fs::is_directory(file, error)) throw std::runtime_error(option + " '" + path + "': is a folder, expected a file");
  check_writable_folder(option, path, file.parent_path().empty() ? fs::path(".") : file.parent_path());
}

void check_output_folder(const std::string& option, const std::string& dir) {
  if (dir.empty()) throw std::runtime_error(option + ": expected a folder name, got an empty one");
  check_writable_folder(option, dir, fs::path(dir));
}

void check_output_files_in(const std::string& option, const std::string& dir, const std::vector<std::string>& names,
                           const std::vector<std::string>& appended) {
  check_output_folder(option, dir);
  auto check = [&](const std::string& name, bool append) {
    const fs::path path = fs::path(dir) / name;
    std::error_code error;
    const fs::file_status status = fs::symlink_status(path, error);
    if (!fs::exists(status)) return;
    if (fs::is_directory(status))
      throw std::runtime_error(option + " '" + dir + "': '" + path.string() + "' is a folder; the command writes a " +
                               "file there (move the folder away)");
    if (!fs::is_regular_file(fs::status(path, error)))
      throw std::runtime_error(option + " '" + dir + "': '" + path.string() + "' is not a regular file; the command " +
                               "writes a file there");
    if (append && !std::ofstream(path, std::ios::app))
      throw std::runtime_error(option + " '" + dir + "': cannot append to '" + path.string() + "'");
  };
  for (const std::string& name : names) check(name, false);
  for (const std::string& name : appended) check(name, true);
}

}  // namespace maps::io
