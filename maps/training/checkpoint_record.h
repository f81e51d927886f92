#pragma once
// What a checkpoint's JSON record says (nn::save's config string), read as untrusted input: every key checked
// against its type and range (a schema per record kind, like the run config's), and the standardizer checked
// against the observations of the data the checkpoint is loaded with.

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "io/config_schema.h"
#include "maps/data/standardizer.h"

namespace maps::core {

// best.ckpt and step_<N>.ckpt: a policy, the step it was taken at, its validation loss where one was computed at
// that step, and the observation standardizer it expects.
struct PolicyRecord {
  std::int64_t step = 0;
  std::optional<double> validation_bc;
  Standardizer standardizer;
};

// last.ckpt: the trainer's state besides the policy and Adam's tensors.
struct TrainingState {
  std::int64_t step = 0;
  std::int64_t best_step = -1;        // -1: no validation yet
  double best_validation = INFINITY;  // null in the record
  std::string rng;                    // std::mt19937_64's state as its operator<< writes it
  // The average of the weights the run keeps (train.ema_power, train.ema_max_decay), recorded since 2026-12-03 by
  // runs keeping one, so that a resumed run can be held to the average it began with; absent: none, or not recorded.
  std::optional<double> ema_power, ema_max_decay;
};

inline constexpr const char* kPolicyRecordFormat = "maps-policy 1";
inline constexpr const char* kTrainingStateFormat = "maps-train 1";
// last.ckpt's tensors: the policy's state dict, Adam's state and (train.ema_power > 0) the average of the parameters,
// each under its prefix.
inline constexpr const char* kTrainingStatePolicyPrefix = "policy.";
inline constexpr const char* kTrainingStateAdamPrefix = "adam.";
inline constexpr const char* kTrainingStateAveragePrefix = "ema.";

nlohmann::json to_json(const PolicyRecord& record);
nlohmann::json to_json(const TrainingState& state);

// The record's "format", or "" when the text is not a JSON object with a string there.
std::string record_format(const std::string& text);

// Reads a policy record from a checkpoint's config text. Throws std::runtime_error naming `where` (the checkpoint's
// path) and the key for text that is not a JSON object, an unknown key, a value out of its range, or a
// standardizer whose mean and std differ in length or, when observation_size >= 0, from the observations'. A
// record without "format" (written before 2026-12-02) is read as kPolicyRecordFormat.
PolicyRecord read_policy_record(const std::string& text, const std::string& where, std::int64_t observation_size);

// Reads last.ckpt's state: every key present and in range, best_step <= step.
TrainingState read_training_state(const std::string& text, const std::string& where);

// The keys of each record (maps schema checkpoint), for docs and for tests that try every key's edge values.
const std::vector<io::Field>& policy_record_schema();
const std::vector<io::Field>& training_state_schema();

}  // namespace maps::core
