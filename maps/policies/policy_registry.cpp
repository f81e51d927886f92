#include "maps/policies/policy_registry.h"

#include <cmath>
#include <deque>
#include <stdexcept>
#include <utility>

namespace maps::core {

namespace {

io::Registry<PolicyMethod>& registry() {
  static io::Registry<PolicyMethod> methods("method", [] {
    // One line per built-in method, in the order help, docs and tables list them.
    // clang-format off
    return std::deque<PolicyMethod>{
        maps_method(),
        single_bc_method(),
        mt_bc_method(),
        mt_mh_bc_method(),
        maml_method(),
        moore_method(),
        paco_method(),
        care_method(),
        top_k_moe_method(),
        soft_modularization_method(),
        diffusion_policy_method(),
    };
    // clang-format on
  });
  return methods;
}

}  // namespace

const std::deque<PolicyMethod>& policy_methods() { return registry().entries(); }

void register_policy_method(PolicyMethod method) {
  if (!method.make || !method.parameters)
    throw std::invalid_argument("method '" + method.name + "': its entry needs a factory (make) and a parameter count");
  registry().add(std::move(method));
}

std::string policy_method_origin(const std::string& name) { return registry().origin_of(name); }

nlohmann::json PolicyMethod::defaults() const {
  nlohmann::json section = nlohmann::json::object();
  for (const io::Field& option : options) section[option.key] = option.default_value;
  return section;
}

std::vector<std::string> policy_method_names() {
  std::vector<std::string> names;
  for (const auto& entry : policy_methods()) names.push_back(entry.name);
  return names;
}

std::string policy_method_list() { return registry().names(); }

const PolicyMethod& policy_method(const std::string& name) {
  for (const auto& entry : policy_methods())
    if (entry.name == name) return entry;
  throw std::invalid_argument("unknown method '" + name + "' (known: " + policy_method_list() + ")");
}

double mlp_parameter_count(const std::vector<std::int64_t>& sizes) {
  double count = 0.0;
  for (std::size_t i = 0; i + 1 < sizes.size(); ++i)
    count += static_cast<double>(sizes[i]) * static_cast<double>(sizes[i + 1]) + static_cast<double>(sizes[i + 1]);
  return count;
}

double maps_parameter_count(const PolicyShape& shape, const MAPSConfig& c) {
  const double M = static_cast<double>(c.modules), A = static_cast<double>(shape.action_size);
  std::vector<std::int64_t> module{shape.observation_size};
  module.insert(module.end(), c.module_hidden.begin(), c.module_hidden.end());
  std::vector<std::int64_t> selector{shape.observation_size + shape.num_tasks};
  selector.insert(selector.end(), c.selector_hidden.begin(), c.selector_hidden.end());
  selector.push_back(c.modules);
  const double features = static_cast<double>(module.back());
  const double selector_count = c.selector == "uniform" ? 0.0 : mlp_parameter_count(selector);
  return M * mlp_parameter_count(module) + selector_count + M * features * A + A;
}

std::int64_t matched_width(double target, const std::function<double(std::int64_t)>& count) {
  std::int64_t low = 1, high = 65536;
  while (low < high) {  // the smallest width reaching the target
    const std::int64_t mid = low + (high - low) / 2;
    if (count(mid) >= target)
      high = mid;
    else
      low = mid + 1;
  }
  if (low > 1 && target - count(low - 1) < count(low) - target) return low - 1;
  return low;
}

std::int64_t option_int(const nlohmann::json& own, const char* key) { return own.at(key).get<std::int64_t>(); }

}  // namespace maps::core
