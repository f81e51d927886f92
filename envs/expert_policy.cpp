#include "envs/expert_policy.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.h"
#include "io/json_input.h"

namespace maps::envs {
namespace {

using nlohmann::json;

constexpr const char* kFormat = "maps.expert_policy";
constexpr int kVersion = 1;

std::string who(const ExpertPolicy& policy) { return "expert policy for task '" + policy.task + "'"; }

json vector_to_json(const Eigen::VectorXd& v) { return json(std::vector<double>(v.data(), v.data() + v.size())); }

json matrix_to_json(const Eigen::MatrixXd& m) {
  json rows = json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    std::vector<double> row(static_cast<std::size_t>(m.cols()));
    for (Eigen::Index c = 0; c < m.cols(); ++c) row[static_cast<std::size_t>(c)] = m(r, c);
    rows.push_back(row);
  }
  return rows;
}

// Field access that names the file and the field on a missing key or a wrong type.
const json& field(const json& object, const std::string& key, const std::string& where) {
  if (!object.is_object()) throw std::runtime_error(where + ": expected a JSON object");
  const auto it = object.find(key);
  if (it == object.end()) throw std::runtime_error(where + ": missing field '" + key + "'");
  return *it;
}

double to_number(const json& value, const std::string& where) {
  if (!value.is_number()) throw std::runtime_error(where + ": expected a number, got " + value.type_name());
  return value.get<double>();
}

Eigen::VectorXd to_vector(const json& value, const std::string& where) {
  if (!value.is_array()) throw std::runtime_error(where + ": expected an array of numbers");
  Eigen::VectorXd v(static_cast<Eigen::Index>(value.size()));
  for (std::size_t i = 0; i < value.size(); ++i) {
    v[static_cast<Eigen::Index>(i)] = to_number(value[i], where + "[" + std::to_string(i) + "]");
  }
  return v;
}

Eigen::MatrixXd to_matrix(const json& value, const std::string& where) {
  if (!value.is_array() || value.empty()) throw std::runtime_error(where + ": expected a non-empty array of rows");
  const std::size_t rows = value.size();
  const std::size_t cols = value[0].is_array() ? value[0].size() : 0;
  Eigen::MatrixXd m(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
  for (std::size_t r = 0; r < rows; ++r) {
    const std::string row_where = where + "[" + std::to_string(r) + "]";
    const Eigen::VectorXd row = to_vector(value[r], row_where);
    if (static_cast<std::size_t>(row.size()) != cols) {
      throw std::runtime_error(row_where + ": has " + std::to_string(row.size()) + " entries, row 0 has " +
                               std::to_string(cols));
    }
    m.row(static_cast<Eigen::Index>(r)) = row.transpose();
  }
  return m;
}

}  // namespace

int ExpertPolicy::observation_size() const { return weights.empty() ? 0 : static_cast<int>(weights.front().cols()); }

int ExpertPolicy::action_size() const { return weights.empty() ? 0 : static_cast<int>(weights.back().rows()); }

Eigen::VectorXd ExpertPolicy::normalize(const Eigen::VectorXd& obs) const {
  if (obs.size() != obs_mean.size() || obs.size() != obs_var.size()) {
    throw std::invalid_argument(who(*this) + ": observation has " + std::to_string(obs.size()) + " entries, expected " +
                                std::to_string(obs_mean.size()));
  }
  return ((obs - obs_mean).array() / (obs_var.array() + obs_epsilon).sqrt()).cwiseMax(-obs_clip).cwiseMin(obs_clip);
}

Eigen::VectorXd ExpertPolicy::mean_action(const Eigen::VectorXd& obs) const {
  if (weights.empty()) throw std::logic_error(who(*this) + ": has no layers");
  Eigen::VectorXd h = normalize(obs);
  for (std::size_t i = 0; i < weights.size(); ++i) {
    h = weights[i] * h + biases[i];
    if (i + 1 < weights.size()) h = h.array().tanh();
  }
  return h;
}

Eigen::VectorXd ExpertPolicy::sample_action(const Eigen::VectorXd& obs, std::mt19937_64& rng) const {
  Eigen::VectorXd action = mean_action(obs);
  if (log_std.size() != action.size()) {
    throw std::logic_error(who(*this) + ": log_std has " + std::to_string(log_std.size()) + " entries, actions have " +
                           std::to_string(action.size()));
  }
  std::normal_distribution<double> normal(0.0, 1.0);
  for (Eigen::Index i = 0; i < action.size(); ++i) action[i] += std::exp(log_std[i]) * normal(rng);
  return action;
}

void ExpertPolicy::validate() const {
  const std::string name = who(*this);
  if (weights.empty()) throw std::invalid_argument(name + ": has no layers");
  if (biases.size() != weights.size()) {
    throw std::invalid_argument(name + ": " + std::to_string(weights.size()) + " weight matrices but " +
                                std::to_string(biases.size()) + " bias vectors");
  }
  for (std::size_t i = 0; i < weights.size(); ++i) {
    const std::string layer = name + ": layer " + std::to_string(i);
    if (weights[i].rows() == 0 || weights[i].cols() == 0) throw std::invalid_argument(layer + " weight is empty");
    if (biases[i].size() != weights[i].rows()) {
      throw std::invalid_argument(layer + " has weight [" + std::to_string(weights[i].rows()) + ", " +
                                  std::to_string(weights[i].cols()) + "] but bias of size " +
                                  std::to_string(biases[i].size()));
    }
    if (i > 0 && weights[i].cols() != weights[i - 1].rows()) {
      throw std::invalid_argument(layer + " takes " + std::to_string(weights[i].cols()) + " inputs but layer " +
                                  std::to_string(i - 1) + " gives " + std::to_string(weights[i - 1].rows()));
    }
    if (!weights[i].allFinite() || !biases[i].allFinite()) {
      throw std::invalid_argument(layer + " has a non-finite weight or bias");
    }
  }
  if (obs_mean.size() != observation_size() || obs_var.size() != observation_size()) {
    throw std::invalid_argument(name + ": obs_mean has " + std::to_string(obs_mean.size()) + " and obs_var " +
                                std::to_string(obs_var.size()) + " entries, the first layer takes " +
                                std::to_string(observation_size()));
  }
  if (!obs_mean.allFinite() || !obs_var.allFinite() || (obs_var.array() < 0.0).any()) {
    throw std::invalid_argument(name + ": obs_mean/obs_var must be finite and obs_var >= 0");
  }
  if (!(obs_clip > 0.0) || !(obs_epsilon >= 0.0) || !std::isfinite(obs_clip) || !std::isfinite(obs_epsilon)) {
    throw std::invalid_argument(name + ": obs_clip must be > 0 and obs_epsilon >= 0 (both finite)");
  }
  if (log_std.size() != action_size()) {
    throw std::invalid_argument(name + ": log_std has " + std::to_string(log_std.size()) +
                                " entries, the last layer gives " + std::to_string(action_size()));
  }
  if (!log_std.allFinite()) throw std::invalid_argument(name + ": log_std has a non-finite entry");
}

void ExpertPolicy::save(const std::string& path) const {
  validate();
  json metadata;
  try {
    metadata = io::parse_json(metadata_json, who(*this) + ": metadata_json");
  } catch (const std::runtime_error& e) {
    throw std::invalid_argument(e.what());
  }
  json layers = json::array();
  for (std::size_t i = 0; i < weights.size(); ++i) {
    layers.push_back({{"weight", matrix_to_json(weights[i])}, {"bias", vector_to_json(biases[i])}});
  }
  // nlohmann writes doubles in their shortest round-trip form, and reads them back exactly.
  const json document = {{"format", kFormat},
                         {"version", kVersion},
                         {"task", task},
                         {"obs_mean", vector_to_json(obs_mean)},
                         {"obs_var", vector_to_json(obs_var)},
                         {"obs_clip", obs_clip},
                         {"obs_epsilon", obs_epsilon},
                         {"layers", layers},
                         {"log_std", vector_to_json(log_std)},
                         {"metadata", metadata}};
  io::write_file_atomically(path, document.dump(1) + "\n", who(*this));
}

ExpertPolicy ExpertPolicy::load(const std::string& path) {
  const std::string where = "expert policy file '" + path + "'";
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(where + ": cannot open (missing or unreadable)");
  std::ostringstream text;
  text << in.rdbuf();
  const json document = io::parse_json(text.str(), where);
  if (!document.is_object()) throw std::runtime_error(where + ": expected a JSON object");
  const json& format = field(document, "format", where);
  if (!format.is_string() || format.get<std::string>() != kFormat) {
    throw std::runtime_error(where + ": field 'format' is not \"" + std::string(kFormat) + "\"");
  }
  // Compared as a 64-bit integer: read as an int, 2^32 + 1 became version 1.
  const json& version = field(document, "version", where);
  const bool supported = version.is_number_unsigned()  ? version.get<std::uint64_t>() == kVersion
                         : version.is_number_integer() ? version.get<std::int64_t>() == kVersion
                                                       : false;
  if (!supported) {
    throw std::runtime_error(where + ": unsupported version " + version.dump() + " (this build reads " +
                             std::to_string(kVersion) + ")");
  }
  std::set<std::string> known;
  for (const io::Field& f : expert_file_schema()) known.insert(f.key);
  for (const auto& [key, value] : document.items())
    if (!known.count(key)) throw std::runtime_error(where + ": unknown field '" + key + "'");
  for (const io::Field& f : expert_file_schema()) {
    // format and version were checked above with their own messages, layers is checked by shape below; a missing
    // field is named where it is read.
    if (f.key == "format" || f.key == "version" || f.key == "layers" || !document.contains(f.key)) continue;
    try {
      io::check_value(f, document.at(f.key), "field ");
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(where + ": " + e.what());
    }
  }
  ExpertPolicy policy;
  const json& task = field(document, "task", where);
  if (!task.is_string()) throw std::runtime_error(where + ": field 'task' must be a string");
  policy.task = task.get<std::string>();
  policy.obs_mean = to_vector(field(document, "obs_mean", where), where + " obs_mean");
  policy.obs_var = to_vector(field(document, "obs_var", where), where + " obs_var");
  policy.obs_clip = to_number(field(document, "obs_clip", where), where + " obs_clip");
  policy.obs_epsilon = to_number(field(document, "obs_epsilon", where), where + " obs_epsilon");
  const json& layers = field(document, "layers", where);
  if (!layers.is_array()) throw std::runtime_error(where + ": field 'layers' must be an array");
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const std::string layer = where + " layers[" + std::to_string(i) + "]";
    policy.weights.push_back(to_matrix(field(layers[i], "weight", layer), layer + ".weight"));
    policy.biases.push_back(to_vector(field(layers[i], "bias", layer), layer + ".bias"));
  }
  policy.log_std = to_vector(field(document, "log_std", where), where + " log_std");
  policy.metadata_json = field(document, "metadata", where).dump();
  try {
    policy.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(where + " is inconsistent: " + e.what());
  }
  return policy;
}

const std::vector<io::Field>& expert_file_schema() {
  static const std::vector<io::Field> schema = [] {
    auto make = [](std::string key, io::ValueKind kind, std::string type, std::string meaning) {
      io::Field f;
      f.key = std::move(key);
      f.kind = kind;
      f.type_name = std::move(type);
      f.meaning = std::move(meaning);
      f.required = true;
      return f;
    };
    std::vector<io::Field> s;
    s.push_back(make("format", io::ValueKind::kString, "string", "the file's kind"));
    s.back().choices = {kFormat};
    s.push_back(make("version", io::ValueKind::kInteger, "int", "the format's version"));
    s.back().min = s.back().max = kVersion;
    s.push_back(make("task", io::ValueKind::kString, "string", "the task the expert was trained on"));
    s.back().non_empty = true;
    s.push_back(make("obs_mean", io::ValueKind::kNumberList, "float list", "the observations' running mean"));
    s.back().non_empty = true;
    s.push_back(make("obs_var", io::ValueKind::kNumberList, "float list", "their running variance"));
    s.back().non_empty = true;
    s.back().min = 0;
    s.push_back(make("obs_clip", io::ValueKind::kNumber, "float", "normalised observations are clipped to +-this"));
    s.back().min = 0;
    s.back().min_exclusive = true;
    s.back().max = 1e6;
    s.push_back(make("obs_epsilon", io::ValueKind::kNumber, "float", "added to the variance before its root"));
    s.back().min = 0;
    s.back().max = 1;
    s.push_back(make("layers", io::ValueKind::kObject, "list of {weight, bias}",
                     "the MLP's layers: weight rows [out][in], bias [out]; each layer takes the last one's outputs"));
    s.push_back(make("log_std", io::ValueKind::kNumberList, "float list", "the Gaussian's log-std per action"));
    s.back().non_empty = true;
    s.push_back(make("metadata", io::ValueKind::kObject, "object", "free-form: training steps, seed, measured return"));
    return s;
  }();
  return schema;
}

}  // namespace maps::envs
