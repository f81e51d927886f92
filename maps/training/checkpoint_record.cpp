#include "maps/training/checkpoint_record.h"

#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "io/json_input.h"

namespace maps::core {
namespace {

using Json = nlohmann::json;

constexpr long double kMaxStep = 1e12;  // as the run config's train.steps
constexpr double kMinStd = 1e-6;        // Standardizer::fit never writes a smaller one

io::Field field(std::string key, io::ValueKind kind, std::string type_name, long double min, long double max,
                std::string meaning) {
  io::Field f;
  f.key = std::move(key);
  f.kind = kind;
  f.type_name = std::move(type_name);
  f.min = min;
  f.max = max;
  f.meaning = std::move(meaning);
  return f;
}

constexpr long double kInf = std::numeric_limits<long double>::infinity();

// The record as an object, with no key outside the schema (nested keys: "standardizer.mean").
Json parse_record(const std::string& text, const std::string& where, const std::vector<io::Field>& schema) {
  const Json record = io::parse_json(text, where + "'s record");
  if (!record.is_object())
    throw std::runtime_error(where + ": the record is " + record.dump().substr(0, 80) + ", not an object");
  std::set<std::string> known;
  for (const io::Field& f : schema) known.insert(f.key.substr(0, f.key.find('.')));
  for (const auto& [key, value] : record.items())
    if (!known.count(key)) throw std::runtime_error(where + ": unknown key '" + key + "' in the record");
  return record;
}

// Checks every field of the schema that is present, and that the required ones are; errors as runtime_error
// naming the checkpoint.
void check_fields(const Json& record, const std::string& where, const std::vector<io::Field>& schema) {
  for (const io::Field& f : schema) {
    const Json* value = io::find_key(record, f.key);
    if (!value) {
      if (f.required) throw std::runtime_error(where + ": the record has no '" + f.key + "'");
      continue;
    }
    try {
      io::check_value(f, *value, "");
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(where + ": record key " + e.what());
    }
  }
}

}  // namespace

const std::vector<io::Field>& policy_record_schema() {
  static const std::vector<io::Field> schema = [] {
    io::Field format = field("format", io::ValueKind::kString, "string", -kInf, kInf,
                             "the record's kind and version (absent before 2026-12-02: read as the first)");
    format.choices = {kPolicyRecordFormat};
    io::Field step = field("step", io::ValueKind::kInteger, "int64", 0, kMaxStep, "the step the policy was taken at");
    step.required = true;
    io::Field validation = field("validation_bc", io::ValueKind::kNumber, "float", 0, kInf,
                                 "the validation BC loss at that step (absent: not validated at that step)");
    io::Field mean = field("standardizer.mean", io::ValueKind::kNumberList, "float list", -kInf, kInf,
                           "the observation mean the policy's inputs are standardised with");
    mean.required = true;
    mean.non_empty = true;
    io::Field stddev = field("standardizer.std", io::ValueKind::kNumberList, "float list", kMinStd, kInf,
                             "the observation standard deviation (Standardizer::fit floors it at 1e-6)");
    stddev.required = true;
    stddev.non_empty = true;
    io::Field clip = field("standardizer.clip", io::ValueKind::kNumber, "float", 0, 1e6,
                           "the bound the standardised inputs are clamped to (data.observation_clip; absent: none)");
    return std::vector<io::Field>{format, step, validation, mean, stddev, clip};
  }();
  return schema;
}

const std::vector<io::Field>& training_state_schema() {
  static const std::vector<io::Field> schema = [] {
    io::Field format = field("format", io::ValueKind::kString, "string", -kInf, kInf, "the record's kind and version");
    format.choices = {kTrainingStateFormat};
    format.required = true;
    io::Field step = field("step", io::ValueKind::kInteger, "int64", 0, kMaxStep, "the steps trained");
    step.required = true;
    io::Field best_step =
        field("best_step", io::ValueKind::kInteger, "int64", -1, kMaxStep, "best.ckpt's step (-1: none yet)");
    best_step.required = true;
    io::Field best_validation = field("best_validation", io::ValueKind::kNumber, "float or null", 0, kInf,
                                      "best.ckpt's validation loss (null: none yet)");
    best_validation.required = true;
    best_validation.nullable = true;
    io::Field rng = field("rng", io::ValueKind::kString, "string", -kInf, kInf, "the batch generator's state");
    rng.required = true;
    rng.non_empty = true;
    io::Field ema_power = field("ema_power", io::ValueKind::kNumber, "float", 0, 10,
                                "train.ema_power of the average the run keeps (absent: none, or not recorded)");
    io::Field ema_max_decay =
        field("ema_max_decay", io::ValueKind::kNumber, "float", 0, 0.999999, "train.ema_max_decay of that average");
    return std::vector<io::Field>{format, step, best_step, best_validation, rng, ema_power, ema_max_decay};
  }();
  return schema;
}

Json to_json(const PolicyRecord& r) {
  const Standardizer& s = r.standardizer;
  Json record{{"format", kPolicyRecordFormat},
              {"step", r.step},
              {"standardizer",
               {{"mean", std::vector<double>(s.mean.data(), s.mean.data() + s.mean.size())},
                {"std", std::vector<double>(s.std.data(), s.std.data() + s.std.size())}}}};
  if (r.validation_bc) record["validation_bc"] = *r.validation_bc;
  if (s.clip > 0.0) record["standardizer"]["clip"] = s.clip;  // absent when 0: the records of runs before the key
  return record;
}

Json to_json(const TrainingState& s) {
  Json record{{"format", kTrainingStateFormat},
              {"step", s.step},
              {"best_step", s.best_step},
              {"best_validation", std::isfinite(s.best_validation) ? Json(s.best_validation) : Json(nullptr)},
              {"rng", s.rng}};
  if (s.ema_power) record["ema_power"] = *s.ema_power;
  if (s.ema_max_decay) record["ema_max_decay"] = *s.ema_max_decay;
  return record;
}

std::string record_format(const std::string& text) {
  try {
    const Json record = io::parse_json(text, "record");
    if (record.is_object() && record.contains("format") && record.at("format").is_string())
      return record.at("format").get<std::string>();
  } catch (const std::runtime_error&) {
  }
  return "";
}

PolicyRecord read_policy_record(const std::string& text, const std::string& where, std::int64_t observation_size) {
  const Json record = parse_record(text, where, policy_record_schema());
  if (record.contains("standardizer")) {
    const Json& s = record.at("standardizer");
    if (!s.is_object())
      throw std::runtime_error(where + ": record key standardizer is " + s.dump().substr(0, 80) + ", not an object");
    for (const auto& [key, value] : s.items())
      if (key != "mean" && key != "std" && key != "clip")
        throw std::runtime_error(where + ": unknown key 'standardizer." + key + "' in the record");
  }
  check_fields(record, where, policy_record_schema());
  PolicyRecord r;
  r.step = record.at("step").get<std::int64_t>();
  if (record.contains("validation_bc")) r.validation_bc = record.at("validation_bc").get<double>();
  const std::vector<double> mean = record.at("standardizer").at("mean");
  const std::vector<double> stddev = record.at("standardizer").at("std");
  if (mean.size() != stddev.size())
    throw std::runtime_error(where + ": the standardizer's mean has " + std::to_string(mean.size()) +
                             " entries and its std " + std::to_string(stddev.size()));
  if (observation_size >= 0 && static_cast<std::int64_t>(mean.size()) != observation_size)
    throw std::runtime_error(where + ": the standardizer is for observations of " + std::to_string(mean.size()) +
                             " entries, the data's have " + std::to_string(observation_size));
  r.standardizer.mean = Eigen::Map<const Eigen::VectorXd>(mean.data(), static_cast<Eigen::Index>(mean.size()));
  r.standardizer.std = Eigen::Map<const Eigen::VectorXd>(stddev.data(), static_cast<Eigen::Index>(stddev.size()));
  if (const Json& s = record.at("standardizer"); s.contains("clip")) r.standardizer.clip = s.at("clip").get<double>();
  return r;
}

TrainingState read_training_state(const std::string& text, const std::string& where) {
  const Json record = parse_record(text, where, training_state_schema());
  check_fields(record, where, training_state_schema());
  TrainingState s;
  s.step = record.at("step").get<std::int64_t>();
  s.best_step = record.at("best_step").get<std::int64_t>();
  if (s.best_step > s.step)
    throw std::runtime_error(where + ": record key best_step " + std::to_string(s.best_step) + " is past step " +
                             std::to_string(s.step));
  if (const Json& best = record.at("best_validation"); !best.is_null()) s.best_validation = best.get<double>();
  s.rng = record.at("rng").get<std::string>();
  if (record.contains("ema_power")) s.ema_power = record.at("ema_power").get<double>();
  if (record.contains("ema_max_decay")) s.ema_max_decay = record.at("ema_max_decay").get<double>();
  return s;
}

}  // namespace maps::core
