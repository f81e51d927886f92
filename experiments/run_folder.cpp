#include "experiments/run_folder.h"

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "envs/demo_file.h"
#include "nn/serialize.h"

namespace maps::experiments {

void write_json_file(const std::string& path, const nlohmann::json& json) {
  nn::write_file_atomically(path, json.dump(2) + "\n");
}

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open '" + path + "'");
  try {
    return nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    throw std::runtime_error("'" + path + "' is not valid JSON: " + e.what());
  }
}

core::DemoDataset load_run_dataset(const core::RunConfig& config) {
  return core::DemoDataset(envs::read_demo_file(config.data_file), config.data);
}

}  // namespace maps::experiments
