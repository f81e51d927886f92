// Expert files (envs/experts/<set>/<task>.json): any bytes either load into a policy that acts on an observation
// of its size, or are refused with an exception.

#include <Eigen/Core>
#include <cstdint>
#include <exception>

#include "envs/expert_policy.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = maps::fuzz::scratch_file(data, size, ".json");
  try {
    const maps::envs::ExpertPolicy expert = maps::envs::ExpertPolicy::load(path);
    expert.mean_action(Eigen::VectorXd::Zero(expert.observation_size()));
  } catch (const std::exception&) {
  }
  return 0;
}
