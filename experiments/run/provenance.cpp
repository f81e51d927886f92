#include "experiments/run/provenance.h"

#include <unistd.h>

#include <array>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <vector>

#include "autograd/ops.h"
#include "experiments/process/command_line.h"
#include "experiments/process/cpu_model.h"
#include "experiments/process/file_digest.h"
#include "experiments/process/host.h"
#include "experiments/process/plugins.h"
#include "experiments/process/version.h"
#include "experiments/run/run_folder.h"

namespace maps::experiments {

nlohmann::json provenance_record(const nlohmann::json& extra) {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0) host[0] = '\0';
  std::error_code error;
  const std::filesystem::path cwd = std::filesystem::current_path(error);
  nlohmann::json record{{"tool_version", tool_version()},
                        {"git_commit", tool_git_commit()},
                        {"started_utc", utc_now()},
                        {"command_line", command_line()},
                        {"working_directory", error ? std::string() : cwd.string()},
                        {"host", std::string(host)},
                        {"cpu", cpu_model()},
                        {"float32_gemm_kernel", ag::float32_gemm_kernel()}};
  // The code from outside the tree that this process ran: each plugin's file, its digest and what it registered.
  for (const LoadedPlugin& plugin : loaded_plugins())
    record["plugins"].push_back({{"path", plugin.path},
                                 {"sha256", plugin.sha256},
                                 {"built_against", plugin.version},
                                 {"registered", plugin.registered}});
  record.update(extra);
  return record;
}

void append_provenance(const std::string& run_dir, const nlohmann::json& record) {
  const std::string path = (std::filesystem::path(run_dir) / run_files::kProvenance).string();
  nlohmann::json records = nlohmann::json::array();
  if (std::filesystem::exists(path)) {
    records = read_json_file(path);
    if (!records.is_array()) throw std::runtime_error("'" + path + "' is not a JSON array of provenance records");
  }
  records.push_back(record);
  write_json_file(path, records);
}

}  // namespace maps::experiments
