#include "experiments/suite_folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <deque>
#include <fstream>
#include <map>
#include <regex>
#include <stdexcept>

#include "experiments/run_folder.h"
#include "maps/training/run_config.h"

namespace maps::experiments {

namespace fs = std::filesystem;
using Json = nlohmann::json;

fs::path cell_dir(const fs::path& out, const SuiteCell& cell) { return out / "cells" / cell.name; }

Json suite_manifest(const Suite& suite, const std::vector<SuiteCell>& cells) {
  Json list = Json::array();
  for (const auto& cell : cells) {
    Json entry = cell.identity();
    entry["request"] = cell.request;
    list.push_back(entry);
  }
  return {{"format", kSuiteFormat}, {"config_file", suite.path}, {"config", suite.source}, {"cells", list}};
}

Suite read_manifest(const fs::path& out) {
  const fs::path path = out / "suite.json";
  if (!fs::exists(path))
    throw std::runtime_error(out.string() + " is not a suite folder: it has no suite.json (maps suite run writes it)");
  const Json manifest = read_json_file(path.string());
  if (!manifest.is_object() || manifest.value("format", "") != kSuiteFormat || !manifest.contains("cells") ||
      !manifest["cells"].is_array())
    throw std::runtime_error(path.string() + ": not a " + std::string(kSuiteFormat) +
                             " manifest (expected \"format\" and \"cells\")");
  Suite suite;
  suite.path = manifest.value("config_file", "");
  suite.source = manifest.value("config", Json::object());
  try {
    for (const auto& entry : manifest["cells"]) {
      SuiteCell cell;
      cell.index = entry.at("index").get<int>();
      cell.name = entry.at("name").get<std::string>();
      cell.grid = entry.at("grid").get<std::string>();
      cell.set = entry.at("set").get<std::string>();
      cell.method = entry.at("method").get<std::string>();
      cell.variant = entry.at("variant").get<std::string>();
      cell.demos = entry.at("demos").get<int>();
      cell.subsample = entry.at("subsample").get<int>();
      cell.seed = entry.at("seed").get<std::uint64_t>();
      cell.request = entry.at("request");
      try {
        core::parse_run_config(cell.request);
      } catch (const std::exception& e) {
        throw std::runtime_error(path.string() + ": cell " + cell.name + " has a damaged run config (" + e.what() +
                                 ")");
      }
      suite.cells.push_back(std::move(cell));
    }
  } catch (const Json::exception& e) {
    throw std::runtime_error(path.string() + ": a cell entry is damaged (" + e.what() + ")");
  }
  return suite;
}

void write_or_check_manifest(const fs::path& out, const Suite& suite) {
  fs::create_directories(out);
  const fs::path path = out / "suite.json";
  std::vector<SuiteCell> cells = suite.cells;
  if (fs::exists(path)) {
    const Suite old = read_manifest(out);
    std::map<std::string, const SuiteCell*> now;
    for (const auto& cell : suite.cells) now[cell.name] = &cell;
    for (const auto& cell : old.cells) {
      const auto found = now.find(cell.name);
      if (found != now.end() && !same_run_config(found->second->request, cell.request))
        throw std::runtime_error(out.string() + " holds a suite whose cell " + cell.name +
                                 " has another run config than " + suite.path +
                                 " gives it; use a new --out, or delete that cell's folder and its entry");
    }
    // Cells of the old manifest that the new config drops stay listed, so status and report still see them.
    for (const auto& cell : old.cells)
      if (!now.count(cell.name)) {
        cells.push_back(cell);
        cells.back().index = static_cast<int>(cells.size()) - 1;
      }
    if (read_json_file(path.string()) == suite_manifest(suite, cells)) return;
  }
  write_json_file(path.string(), suite_manifest(suite, cells));
}

bool same_run_config(const Json& a, const Json& b) {
  if (a == b) return true;
  try {
    return core::to_json(core::parse_run_config(a)) == core::to_json(core::parse_run_config(b));
  } catch (const std::exception&) {
    return false;
  }
}

bool is_temporary(const fs::path& file) {
  const std::string name = file.filename().string();
  return name.find(".tmp-") != std::string::npos || name.ends_with(".tmp") || name.ends_with(".partial.h5");
}

void remove_temporaries(const fs::path& dir) {
  if (!fs::exists(dir)) return;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.is_regular_file() && is_temporary(entry.path())) fs::remove(entry.path());
}

std::optional<Json> read_result(const fs::path& dir, const SuiteCell& cell, std::string* damage) {
  if (damage) damage->clear();
  const fs::path path = dir / "result.json";
  if (!fs::exists(path)) return std::nullopt;
  auto reject = [&](const std::string& why) -> std::optional<Json> {
    if (damage) *damage = path.string() + ": " + why;
    return std::nullopt;
  };
  Json result;
  try {
    result = read_json_file(path.string());
  } catch (const std::exception& e) {
    return reject("unreadable (" + std::string(e.what()) + ")");
  }
  if (!result.is_object() || result.value("format", "") != kCellFormat) return reject("not a maps-suite-cell/1 result");
  if (!result.contains("cell") || !result["cell"].is_object() || result["cell"].value("name", "") != cell.name)
    return reject("names another cell");
  if (!result.contains("config") || !same_run_config(result["config"], cell.request))
    return reject("was trained with another run config");
  const auto number = [](const Json& object, const char* key) {
    return object.is_object() && object.contains(key) && object[key].is_number();
  };
  if (!result.contains("train") || !number(result["train"], "steps") || !number(result["train"], "best_step") ||
      !number(result["train"], "best_validation_bc"))
    return reject("has no training summary (steps, best_step, best_validation_bc)");
  const Json& eval = result.contains("eval") ? result["eval"] : Json();
  if (!number(eval, "mean_score") || !number(eval, "best_step") || !eval.contains("tasks") ||
      !eval["tasks"].is_array() || eval["tasks"].empty())
    return reject("has no evaluation (mean_score, best_step, tasks)");
  for (const auto& task : eval["tasks"])
    if (!number(task, "score") || !task.contains("task") || !task["task"].is_string())
      return reject("has an evaluation task without a name or a score");
  return result;
}

CellLock::CellLock(const fs::path& dir) {
  fs::create_directories(dir);
  const std::string path = (dir / ".lock").string();
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::runtime_error("cannot open '" + path + "': " + std::strerror(errno));
  // A few tries: `maps suite status` probes the lock for an instant (a shared lock), which must not make a
  // runner skip the cell.
  for (int attempt = 0; attempt < 5; ++attempt) {
    if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return;
    ::usleep(20000);
  }
  ::close(fd_);
  fd_ = -1;
}

CellLock::~CellLock() {
  if (fd_ >= 0) ::close(fd_);
}

bool cell_is_locked(const fs::path& dir) {
  const std::string path = (dir / ".lock").string();
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool locked = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return locked;
}

fs::path source_dir(const fs::path& dir, const SuiteCell& cell) {
  const std::string relative = cell.request.contains("init") ? cell.request["init"].value("run", "") : "";
  return relative.empty() ? fs::path() : (dir / relative).lexically_normal();
}

fs::path source_checkpoint(const fs::path& dir, const SuiteCell& cell) {
  const fs::path source = source_dir(dir, cell);
  if (source.empty()) return {};
  return source / cell.request["init"].value("checkpoint", "best.ckpt");
}

void clear_cell(const fs::path& dir) {
  if (!fs::exists(dir)) return;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().filename() != ".lock" && entry.path().filename() != kReplacedFolder) fs::remove_all(entry.path());
}

fs::path replaced_folder(const fs::path& dir, std::string finished) {
  std::replace(finished.begin(), finished.end(), ':', '-');
  // It names a folder: anything but a time as utc_now writes it (a hand-edited result) is not trusted.
  static const std::regex time_like(R"(\d{4}-\d{2}-\d{2}T\d{2}-\d{2}-\d{2}Z)");
  if (!std::regex_match(finished, time_like)) finished = "unknown";
  fs::path kept = dir / kReplacedFolder / finished;
  // A folder without result.json is this cell's own, left half moved by a crash in retire_cell.
  for (int n = 2; fs::exists(kept / "result.json"); ++n)
    kept = dir / kReplacedFolder / (finished + "-" + std::to_string(n));
  return kept;
}

fs::path retire_cell(const fs::path& dir) {
  std::string finished;
  try {
    finished = read_json_file((dir / "result.json").string()).value("finished", finished);
  } catch (const std::exception&) {
  }
  const fs::path kept = replaced_folder(dir, finished);
  fs::create_directories(kept);
  // result.json last: a cell whose result.json is still in place after a crash here is retired again.
  for (const char* name : {"curve.csv", "result.json"})
    if (fs::exists(dir / name)) fs::rename(dir / name, kept / name);
  clear_cell(dir);
  return kept;
}

std::string tail_of(const fs::path& path, int lines) {
  std::ifstream in(path);
  std::deque<std::string> last;
  for (std::string line; std::getline(in, line);) {
    last.push_back(line);
    if (static_cast<int>(last.size()) > lines) last.pop_front();
  }
  std::string out;
  for (const auto& line : last) out += (out.empty() ? "" : "\n") + line;
  return out;
}

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof(name) - 1) != 0) return "unknown";
  return name;
}

}  // namespace maps::experiments
