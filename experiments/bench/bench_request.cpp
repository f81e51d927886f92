#include "experiments/bench/bench_request.h"

#include <utility>

#include "experiments/process/plugins.h"
#include "experiments/run/run_folder.h"

namespace maps::experiments {

nlohmann::json bench_request(const std::string& method, const std::string& config_path, const std::string& who) {
  nlohmann::json request{{"method", method}, {"data", {{"file", "unused by " + who}}}};
  if (config_path.empty()) return request;
  const std::string where = "--config '" + config_path + "'";
  nlohmann::json given = load_config_plugins(read_json_file(config_path), folder_of(config_path), where);
  given.merge_patch(request);  // --method and the unused data file over the config's
  return given;
}

}  // namespace maps::experiments
