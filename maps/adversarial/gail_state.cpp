#include "maps/adversarial/gail_state.h"

#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "nn/serialize.h"

namespace maps::adversarial {
namespace {

using Json = nlohmann::json;

const char* const kPrefixes[] = {"policy.", "head.", "discriminator.", "adam.", "discriminator_adam."};
constexpr const char* kReturnStats = "return_stats";

std::string engine_text(const std::mt19937_64& engine) {
  std::ostringstream text;
  text << engine;
  return text.str();
}

void read_engine(const Json& record, const char* key, std::mt19937_64& engine, const std::string& where) {
  if (!record.contains(key) || !record[key].is_string())
    throw std::runtime_error(where + ": \"" + key + "\" must be a random engine's state as text");
  std::istringstream text(record[key].get<std::string>());
  std::mt19937_64 read;
  text >> read;
  if (text.fail()) throw std::runtime_error(where + ": \"" + key + "\" is not a random engine's state");
  engine = read;
}

constexpr std::int64_t kMaxEnvStepsPerTask = 1'000'000'000'000LL;

std::int64_t read_count(const Json& record, const char* key, std::int64_t low, const std::string& where) {
  if (!record.contains(key) || !record[key].is_number_integer() || record[key].get<std::int64_t>() < low)
    throw std::runtime_error(where + ": \"" + key + "\" must be a whole number >= " + std::to_string(low));
  return record[key].get<std::int64_t>();
}

}  // namespace

void save_gail_state(const std::string& path, const GailState& state, const GailModules& modules,
                     const std::mt19937_64& rng, const ag::Generator& noise) {
  nn::NamedTensors tensors;
  nn::append_with_prefix(tensors, modules.policy.state_dict(), kPrefixes[0]);
  nn::append_with_prefix(tensors, modules.head.state_dict(), kPrefixes[1]);
  nn::append_with_prefix(tensors, modules.discriminator.state_dict(), kPrefixes[2]);
  nn::append_with_prefix(tensors, modules.adam.state(), kPrefixes[3]);
  nn::append_with_prefix(tensors, modules.discriminator_adam.state(), kPrefixes[4]);
  const auto K = static_cast<std::int64_t>(modules.reward_scalers.size());
  std::vector<double> stats;
  for (const auto& scaler : modules.reward_scalers) {
    stats.push_back(scaler.stats().mean()(0));
    stats.push_back(scaler.stats().var()(0));
    stats.push_back(scaler.stats().count());
  }
  tensors.push_back({kReturnStats, ag::from_vector(stats, {K, 3}, ag::Dtype::Float64)});
  ag::Generator noise_copy = noise;
  Json record{{"format", kGailStateFormat},
              {"iteration", state.iteration},
              {"env_steps_per_task", state.env_steps_per_task},
              {"best_iteration", state.best_iteration},
              {"best_validation", std::isfinite(state.best_validation) ? Json(state.best_validation) : Json(nullptr)},
              {"rng", engine_text(rng)},
              {"noise", engine_text(noise_copy.engine())}};
  nn::save_tensors(path, tensors, record.dump());
}

GailState read_gail_record(const std::string& text, const std::string& where, std::mt19937_64* rng,
                           std::mt19937_64* noise) {
  Json record;
  try {
    record = Json::parse(text);
  } catch (const std::exception& e) {
    throw std::runtime_error(where + ": its record is not JSON (" + e.what() + ")");
  }
  if (!record.is_object() || record.value("format", std::string()) != kGailStateFormat)
    throw std::runtime_error(where + ": not a GAIL training state (expected \"format\": \"" +
                             std::string(kGailStateFormat) + "\"; a BC run's last.ckpt cannot resume as GAIL)");
  for (const auto& [key, value] : record.items())
    if (key != "format" && key != "iteration" && key != "env_steps_per_task" && key != "best_iteration" &&
        key != "best_validation" && key != "rng" && key != "noise")
      throw std::runtime_error(where + ": unknown key \"" + key + "\"");
  GailState state;
  state.iteration = read_count(record, "iteration", 1, where);
  state.env_steps_per_task = read_count(record, "env_steps_per_task", 1, where);
  state.best_iteration = read_count(record, "best_iteration", 0, where);
  // Every iteration takes at least one env step per task; the bound is far above any budget (gail.env_steps_per_task
  // is at most 10^10), so the counters' products cannot overflow.
  if (state.env_steps_per_task > kMaxEnvStepsPerTask || state.iteration > state.env_steps_per_task)
    throw std::runtime_error(where + ": iteration " + std::to_string(state.iteration) + " and env_steps_per_task " +
                             std::to_string(state.env_steps_per_task) +
                             " must satisfy iteration <= env_steps_per_task <= 10^12");
  if (state.best_iteration > state.iteration)
    throw std::runtime_error(where + ": best_iteration " + std::to_string(state.best_iteration) +
                             " is after the iteration " + std::to_string(state.iteration));
  const Json& best = record.contains("best_validation") ? record["best_validation"] : Json();
  if (best.is_null()) {
    state.best_validation = INFINITY;
  } else if (best.is_number() && std::isfinite(best.get<double>()) && best.get<double>() >= 0.0) {
    state.best_validation = best.get<double>();
  } else {
    throw std::runtime_error(where + ": \"best_validation\" must be a non-negative number or null");
  }
  std::mt19937_64 engine;
  read_engine(record, "rng", rng ? *rng : engine, where);
  read_engine(record, "noise", noise ? *noise : engine, where);
  return state;
}

std::int64_t gail_iterations_done(const std::string& last_checkpoint) {
  if (!std::filesystem::exists(last_checkpoint)) return 0;
  return read_gail_record(nn::load_tensors(last_checkpoint).config, "GAIL checkpoint " + last_checkpoint).iteration;
}

GailState load_gail_state(const std::string& path, GailModules& modules, std::mt19937_64& rng, ag::Generator& noise) {
  const std::string where = "GAIL checkpoint " + path;
  const nn::Checkpoint checkpoint = nn::load_tensors(path);
  std::mt19937_64 read_rng, read_noise;
  const GailState state = read_gail_record(checkpoint.config, where, &read_rng, &read_noise);

  const auto K = static_cast<std::int64_t>(modules.reward_scalers.size());
  const ag::Tensor* stats = nullptr;
  for (const auto& t : checkpoint.tensors)
    if (t.name == kReturnStats) stats = &t.tensor;
  if (!stats || stats->shape() != ag::Shape{K, 3})
    throw std::runtime_error(where + ": \"return_stats\" must be a [" + std::to_string(K) + ", 3] tensor");
  const ag::RowMatrixD values = ag::to_eigen_double(*stats);
  for (std::int64_t k = 0; k < K; ++k)
    if (!std::isfinite(values(k, 0)) || !(values(k, 1) >= 0.0) || !std::isfinite(values(k, 1)) ||
        !(values(k, 2) > 0.0) || !std::isfinite(values(k, 2)))
      throw std::runtime_error(where + ": return_stats row " + std::to_string(k) +
                               " must hold a finite mean, a variance >= 0 and a count > 0");
  for (const auto& t : checkpoint.tensors) {
    bool known = t.name == kReturnStats;
    for (const char* prefix : kPrefixes) known = known || t.name.rfind(prefix, 0) == 0;
    if (!known) throw std::runtime_error(where + ": unknown tensor \"" + t.name + "\"");
  }
  try {
    modules.policy.load_state_dict(nn::strip_prefix(checkpoint.tensors, kPrefixes[0]));
    modules.head.load_state_dict(nn::strip_prefix(checkpoint.tensors, kPrefixes[1]));
    modules.discriminator.load_state_dict(nn::strip_prefix(checkpoint.tensors, kPrefixes[2]));
    modules.adam.load_state(nn::strip_prefix(checkpoint.tensors, kPrefixes[3]));
    modules.discriminator_adam.load_state(nn::strip_prefix(checkpoint.tensors, kPrefixes[4]));
  } catch (const std::exception& e) {
    throw std::runtime_error(where + " does not fit this run's modules: " + e.what());
  }
  for (std::int64_t k = 0; k < K; ++k) {
    rl::RunningMeanStd stats(1);
    stats.set_state(Eigen::VectorXd::Constant(1, values(k, 0)), Eigen::VectorXd::Constant(1, values(k, 1)),
                    values(k, 2));
    modules.reward_scalers[static_cast<std::size_t>(k)].set_state(0.0, stats);
  }
  rng = read_rng;
  noise.engine() = read_noise;
  return state;
}

}  // namespace maps::adversarial
