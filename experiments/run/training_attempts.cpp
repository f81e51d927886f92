#include "experiments/run/training_attempts.h"

#include <exception>
#include <string>

#include "experiments/run/run_folder.h"

namespace maps::experiments {

nlohmann::json training_attempts(const std::filesystem::path& dir) {
  nlohmann::json attempts = nlohmann::json::array();
  const std::filesystem::path path = dir / run_files::kProvenance;
  if (!std::filesystem::exists(path)) return attempts;
  nlohmann::json records;
  try {
    records = read_json_file(path.string());
  } catch (const std::exception& e) {
    // maps train refuses a damaged provenance.json, so this is a file changed since: say so, keep the result.
    return nlohmann::json::array({{{"error", std::string("unreadable ") + path.string() + ": " + e.what()}}});
  }
  if (!records.is_array())
    return nlohmann::json::array({{{"error", path.string() + " is not a JSON array of provenance records"}}});
  for (const auto& record : records) {
    if (!record.is_object()) continue;
    const auto subcommand = record.find("subcommand");
    if (subcommand == record.end() || !subcommand->is_string() || *subcommand != "train") continue;
    const auto start = record.find("start_step");
    const auto steps = record.find("steps");
    if (start != record.end() && steps != record.end() && start->is_number_integer() && steps->is_number_integer() &&
        start->get<long long>() >= steps->get<long long>())
      continue;
    nlohmann::json attempt = nlohmann::json::object();
    for (const char* key : {"started_utc", "git_commit", "cpu", "float32_gemm_kernel", "matmul_precision", "threads",
                            "start_step", "steps"})
      if (record.contains(key)) attempt[key] = record[key];
    attempts.push_back(attempt);
  }
  return attempts;
}

}  // namespace maps::experiments
