#include "experiments/run/config_overrides.h"

#include <stdexcept>

#include "io/json_input.h"

namespace maps::experiments {

void apply_overrides(nlohmann::json& config, const std::vector<std::string>& assignments) {
  if (!assignments.empty() && !config.is_object())
    throw std::invalid_argument("--set: the config is " + std::string(config.type_name()) + ", not a JSON object");
  for (const std::string& assignment : assignments) {
    const std::size_t equals = assignment.find('=');
    if (equals == std::string::npos)
      throw std::invalid_argument("--set '" + assignment + "': expected key=value, e.g. train.steps=40000");
    const std::string key = assignment.substr(0, equals), text = assignment.substr(equals + 1);
    std::vector<std::string> parts;
    for (std::size_t start = 0;;) {
      const std::size_t dot = key.find('.', start);
      parts.push_back(key.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
      if (dot == std::string::npos) break;
      start = dot + 1;
    }
    for (const std::string& part : parts)
      if (part.empty())
        throw std::invalid_argument("--set '" + assignment + "': the key '" + key +
                                    "' has an empty part (keys look like train.steps)");
    // A value that is not JSON is a string (method=mt_bc); one nested too deep is refused, not taken as a string.
    nlohmann::json value;
    try {
      value = io::parse_json(text, "--set '" + key + "'");
    } catch (const io::JsonTooDeep& e) {
      throw std::invalid_argument(e.what());
    } catch (const std::runtime_error&) {
      value = text;
    }
    nlohmann::json* node = &config;
    std::string path;
    for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
      path += (path.empty() ? "" : ".") + parts[i];
      if (!node->contains(parts[i])) (*node)[parts[i]] = nlohmann::json::object();
      node = &(*node)[parts[i]];
      if (!node->is_object())
        throw std::invalid_argument("--set '" + assignment + "': '" + path + "' is " + node->dump() +
                                    ", not an object with keys");
    }
    (*node)[parts.back()] = value;
  }
}

}  // namespace maps::experiments
