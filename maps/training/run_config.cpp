#include "maps/training/run_config.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <type_traits>

#include "envs/portable_random.h"

namespace maps::core {
namespace {

using Json = nlohmann::json;

void check_keys(const Json& json, const std::string& where, const std::set<std::string>& known) {
  if (!json.is_object()) throw std::invalid_argument("config " + where + ": expected a JSON object");
  for (const auto& [key, value] : json.items()) {
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw std::invalid_argument("config " + where + ": unknown key '" + key + "' (known: " + list + ")");
    }
  }
}

// nlohmann converts any number to an integer (2.5 -> 2, 1.2e9 -> 1200000000, -1 -> 2^64 - 1 for unsigned): an
// integer field must hold an integer of its sign.
template <typename T>
bool fits(const Json& value) {
  if constexpr (std::is_same_v<T, bool>) {
    return value.is_boolean();
  } else if constexpr (std::is_integral_v<T> && std::is_unsigned_v<T>) {
    return value.is_number_unsigned();
  } else if constexpr (std::is_integral_v<T>) {
    return value.is_number_integer();
  } else if constexpr (std::is_floating_point_v<T>) {
    return value.is_number();
  } else if constexpr (std::is_same_v<T, std::string>) {
    return value.is_string();
  } else {
    if (!value.is_array()) return false;
    for (const Json& element : value)
      if (!fits<typename T::value_type>(element)) return false;
    return true;
  }
}

// What a value of type T is, in a config error.
template <typename T>
std::string expected_kind() {
  if constexpr (std::is_same_v<T, bool>) {
    return "true or false";
  } else if constexpr (std::is_integral_v<T> && std::is_unsigned_v<T>) {
    return "an integer >= 0";
  } else if constexpr (std::is_integral_v<T>) {
    return "an integer";
  } else if constexpr (std::is_floating_point_v<T>) {
    return "a number";
  } else if constexpr (std::is_same_v<T, std::string>) {
    return "a string";
  } else {
    return "a list of " + expected_kind<typename T::value_type>().substr(2) + "s";
  }
}

template <typename T>
void read(const Json& json, const std::string& where, const char* key, T& out) {
  if (!json.contains(key)) return;
  const Json& value = json.at(key);
  if (!fits<T>(value))
    throw std::invalid_argument("config " + where + (where.empty() ? "" : ".") + key + ": wrong type (" + value.dump() +
                                "), expected " + expected_kind<T>());
  out = value.get<T>();
}

// An object of name: number (data.task_demos, train.lr_scale, maps.selector_losses), by name, each number
// accepted by `valid`; `shape` and `expected` say what the object and each number must be.
template <typename T, typename Valid>
std::vector<std::pair<std::string, T>> read_named_numbers(const Json& object, const std::string& where,
                                                          const std::string& shape, const std::string& expected,
                                                          Valid valid) {
  if (!object.is_object())
    throw std::invalid_argument("config " + where + ": expected an object of " + shape + ", got " + object.dump());
  std::vector<std::pair<std::string, T>> out;
  for (const auto& [name, value] : object.items()) {
    if (!valid(value))
      throw std::invalid_argument("config " + where + "." + name + ": expected " + expected + ", got " + value.dump());
    out.emplace_back(name, value.template get<T>());
  }
  return out;
}

// Far above any model the paper or this library trains (MAPS at M = 20: about 0.8M); a bigger request is a typo
// (a size of 12E8) that would otherwise fail deep inside an allocation.
constexpr double kMaxParameters = 1e8;

// A value of a method's own section must have its default's JSON type.
bool same_kind(const Json& value, const Json& default_value) {
  if (default_value.is_boolean()) return value.is_boolean();
  if (default_value.is_number_integer()) return value.is_number_integer();
  if (default_value.is_number()) return value.is_number();
  if (default_value.is_string()) return value.is_string();
  if (default_value.is_array()) {
    if (!value.is_array()) return false;
    for (const Json& element : value)
      if (!default_value.empty() && !same_kind(element, default_value.front())) return false;
    return true;
  }
  if (default_value.is_object()) return value.is_object();
  return false;
}

std::string kind_name(const Json& default_value) {
  if (default_value.is_boolean()) return "true or false";
  if (default_value.is_number_integer()) return "an integer";
  if (default_value.is_number()) return "a number";
  if (default_value.is_string()) return "a string";
  if (default_value.is_array())
    return default_value.empty() ? "an array" : "an array of " + kind_name(default_value.front()).substr(2) + "s";
  return "an object";
}

// A registered method's own section: known keys of its defaults' types, then the method's range checks.
Json read_method_section(const PolicyMethod& method, const Json& given) {
  std::set<std::string> known;
  for (const auto& [key, value] : method.defaults.items()) known.insert(key);
  check_keys(given, method.name, known);
  Json filled = method.defaults;
  for (const auto& [key, value] : given.items()) {
    const Json& default_value = method.defaults.at(key);
    if (!same_kind(value, default_value))
      throw std::invalid_argument("config " + method.name + "." + key + ": wrong type (" + value.dump() +
                                  "), expected " + kind_name(default_value));
    filled[key] = value;
  }
  if (method.check) method.check(filled);
  return filled;
}

}  // namespace

RunConfig parse_run_config(const Json& json) {
  RunConfig c;
  std::set<std::string> top_keys = {"method", "seed", "data", "train", "maps", "maml", "baselines", "eval", "init"};
  for (const auto& method : policy_methods())
    if (!method.defaults.empty()) top_keys.insert(method.name);
  check_keys(json, "", top_keys);
  read(json, "", "method", c.method);
  const PolicyMethod* chosen = nullptr;
  for (const auto& method : policy_methods()) {
    if (method.name == c.method) chosen = &method;
    // Every registered section present is checked (a typo in another method's section is still a typo).
    if (!method.defaults.empty() && json.contains(method.name)) {
      Json filled = read_method_section(method, json.at(method.name));
      if (method.name == c.method) c.method_options = std::move(filled);
    }
  }
  if (!chosen) throw std::invalid_argument("config method: '" + c.method + "' is not one of " + policy_method_list());
  if (!chosen->defaults.empty() && !json.contains(c.method)) c.method_options = chosen->defaults;
  read(json, "", "seed", c.seed);
  if (!json.contains("data")) throw std::invalid_argument("config: \"data\": {\"file\": ...} is required");
  const Json& data = json["data"];
  check_keys(data, "data", {"file", "demos_per_task", "subsample", "tasks", "holdout", "task_demos", "draws"});
  read(data, "data", "file", c.data_file);
  if (c.data_file.empty()) throw std::invalid_argument("config data.file: required");
  read(data, "data", "demos_per_task", c.data.demos_per_task);
  read(data, "data", "subsample", c.data.subsample);
  read(data, "data", "tasks", c.data.tasks);
  read(data, "data", "holdout", c.data.holdout);
  read(data, "data", "draws", c.data.draws);
  check_draws(c.data.draws);
  if (data.contains("task_demos"))
    c.data.task_demos = read_named_numbers<int>(
        data["task_demos"], "data.task_demos", "task name: demonstrations", "an integer >= 1", [](const Json& count) {
          return count.is_number_integer() && count.get<std::int64_t>() >= 1 && count.get<std::int64_t>() <= 1000000;
        });
  for (const auto& [name, count] : c.data.task_demos) {
    const bool held_out = std::find(c.data.holdout.begin(), c.data.holdout.end(), name) != c.data.holdout.end();
    const bool left_out =
        !c.data.tasks.empty() && std::find(c.data.tasks.begin(), c.data.tasks.end(), name) == c.data.tasks.end();
    if (held_out || left_out)
      throw std::invalid_argument("config data.task_demos." + name + ": the task is not trained (" +
                                  (held_out ? "it is in data.holdout" : "data.tasks leaves it out") +
                                  "), so its count would do nothing");
  }
  c.data.seed = c.seed;
  if (json.contains("train")) {
    const Json& t = json["train"];
    check_keys(t, "train",
               {"steps", "learning_rate", "states_per_task", "validate_every", "checkpoint_every",
                "validation_states_per_task", "keep_every", "bc_loss", "freeze", "lr_scale", "flush_denormal",
                "validation_tasks", "optimizer", "adam_eps"});
    read(t, "train", "steps", c.train.steps);
    read(t, "train", "learning_rate", c.train.learning_rate);
    read(t, "train", "states_per_task", c.train.states_per_task);
    read(t, "train", "validate_every", c.train.validate_every);
    read(t, "train", "checkpoint_every", c.train.checkpoint_every);
    read(t, "train", "validation_states_per_task", c.train.validation_states_per_task);
    read(t, "train", "keep_every", c.train.keep_every);
    read(t, "train", "bc_loss", c.train.bc_loss);
    read(t, "train", "freeze", c.train.freeze);
    read(t, "train", "flush_denormal", c.train.flush_denormal);
    read(t, "train", "validation_tasks", c.train.validation_tasks);
    read(t, "train", "optimizer", c.train.optimizer);
    read(t, "train", "adam_eps", c.train.adam_eps);
    if (c.train.optimizer != "joint" && c.train.optimizer != "alternating")
      throw std::invalid_argument("config train.optimizer: expected \"joint\" or \"alternating\", got \"" +
                                  c.train.optimizer + "\"");
    // Adam adds eps in float32, where a value below about 1e-30 is lost to rounding (or flushed to 0) and a step
    // divides by zero.
    if (!(c.train.adam_eps >= 1e-30) || !(c.train.adam_eps <= 1.0))
      throw std::invalid_argument(
          "config train.adam_eps: expected a number in [1e-30, 1] (float32 training: smaller "
          "values round to 0), got " +
          t["adam_eps"].dump());
    if (t.contains("lr_scale"))
      c.train.lr_scale = read_named_numbers<double>(t["lr_scale"], "train.lr_scale", "parameter-name prefix: factor",
                                                    "a finite number >= 0", [](const Json& factor) {
                                                      return factor.is_number() && factor.get<double>() >= 0.0 &&
                                                             std::isfinite(factor.get<double>());
                                                    });
    for (const auto& [prefix, factor] : c.train.lr_scale)
      for (const auto& frozen : c.train.freeze)
        if (prefix.rfind(frozen, 0) == 0)  // every parameter under the prefix is frozen
          throw std::invalid_argument("config train.lr_scale." + prefix +
                                      ": parameters under it are frozen (train.freeze \"" + frozen +
                                      "\"), so their learning rate does nothing");
    if (c.train.bc_loss != "mean" && c.train.bc_loss != "sampled")
      throw std::invalid_argument("config train.bc_loss: expected \"mean\" or \"sampled\", got \"" + c.train.bc_loss +
                                  "\"");
    if (c.train.bc_loss == "sampled" && !chosen->sampled_bc_loss)
      throw std::invalid_argument("config train.bc_loss: \"sampled\" is not available for " + c.method +
                                  " (its inner and fine-tuning steps use the mean's squared error); use \"mean\"");
  }
  c.train.seed = c.seed;
  if (json.contains("maps")) {
    const Json& m = json["maps"];
    check_keys(m, "maps",
               {"modules", "module_hidden", "selector_hidden", "activation", "bc_weight", "selector_weight",
                "selector_losses", "selector", "observations"});
    read(m, "maps", "modules", c.maps.modules);
    read(m, "maps", "module_hidden", c.maps.module_hidden);
    read(m, "maps", "selector_hidden", c.maps.selector_hidden);
    read(m, "maps", "activation", c.maps.activation);
    read(m, "maps", "bc_weight", c.maps.bc_weight);
    read(m, "maps", "selector_weight", c.maps.selector_weight);
    read(m, "maps", "selector", c.maps.selector);
    read(m, "maps", "observations", c.maps.observations);
    if (c.maps.modules < 1)
      throw std::invalid_argument("config maps.modules: expected at least 1, got " + std::to_string(c.maps.modules));
    if (c.maps.module_hidden.empty())
      throw std::invalid_argument("config maps.module_hidden: expected at least one layer size (the features)");
    for (const auto* sizes : {&c.maps.module_hidden, &c.maps.selector_hidden})
      for (const std::int64_t size : *sizes)
        if (size < 1)
          throw std::invalid_argument(std::string("config maps.") +
                                      (sizes == &c.maps.module_hidden ? "module_hidden" : "selector_hidden") +
                                      ": layer sizes must be >= 1, got " + std::to_string(size));
    if (c.maps.observations != "standardized" && c.maps.observations != "raw_clipped")
      throw std::invalid_argument("config maps.observations: expected \"standardized\" or \"raw_clipped\", got \"" +
                                  c.maps.observations + "\"");
    if (!is_selector_kind(c.maps.selector))
      throw std::invalid_argument(std::string("config maps.selector: expected ") + kSelectorKinds + ", got \"" +
                                  c.maps.selector + "\"");
    if (m.contains("selector_losses"))
      c.maps.selector_losses =
          read_named_numbers<double>(m["selector_losses"], "maps.selector_losses", "name: weight", "a number",
                                     [](const Json& weight) { return weight.is_number(); });
  }
  if (json.contains("maml")) {
    const Json& m = json["maml"];
    check_keys(m, "maml", {"inner_lr", "inner_steps", "first_order", "query_per_task", "finetune_steps", "validate"});
    read(m, "maml", "inner_lr", c.maml.inner_lr);
    read(m, "maml", "inner_steps", c.maml.inner_steps);
    read(m, "maml", "first_order", c.maml.first_order);
    read(m, "maml", "query_per_task", c.maml.query_per_task);
    read(m, "maml", "finetune_steps", c.maml.finetune_steps);
    read(m, "maml", "validate", c.maml.validate);
    if (c.maml.validate != "unadapted" && c.maml.validate != "adapted")
      throw std::invalid_argument("config maml.validate: expected \"unadapted\" or \"adapted\", got \"" +
                                  c.maml.validate + "\"");
  }
  c.maml.finetune_seed = c.seed;
  if (json.contains("baselines")) {
    const Json& b = json["baselines"];
    check_keys(b, "baselines", {"hidden"});
    if (b.contains("hidden")) {
      const Json& hidden = b["hidden"];
      if (!hidden.is_array() || hidden.empty())
        throw std::invalid_argument("config baselines.hidden: expected a non-empty array of layer sizes, got " +
                                    hidden.dump());
      c.baseline_hidden.clear();
      for (const Json& size : hidden) {
        if (!size.is_number_integer() || size.get<std::int64_t>() < 1)
          throw std::invalid_argument("config baselines.hidden: sizes must be integers >= 1, got " + size.dump());
        c.baseline_hidden.push_back(size.get<std::int64_t>());
      }
    }
    if (!chosen->uses_baselines_hidden && c.baseline_hidden != detail::default_hidden_sizes())
      throw std::invalid_argument("config baselines.hidden: " + c.method + " has no baseline MLP (its sizes are " +
                                  chosen->size_keys + ")");
  }
  if (json.contains("init")) {
    const Json& init = json["init"];
    check_keys(init, "init", {"run", "checkpoint"});
    read(init, "init", "run", c.init_run);
    read(init, "init", "checkpoint", c.init_checkpoint);
    if (c.init_checkpoint.empty() || c.init_checkpoint.find('/') != std::string::npos || c.init_checkpoint == "." ||
        c.init_checkpoint == "..")
      throw std::invalid_argument(
          "config init.checkpoint: expected a file name of the run folder (best.ckpt, "
          "step_<N>.ckpt), got \"" +
          c.init_checkpoint + "\"");
  }
  if (json.contains("eval")) {
    const Json& e = json["eval"];
    check_keys(e, "eval", {"episodes", "threads", "tasks"});
    read(e, "eval", "episodes", c.eval_episodes);
    read(e, "eval", "threads", c.eval_threads);
    read(e, "eval", "tasks", c.eval_tasks);
  }
  return c;
}

Json transfer_request(Json request, const std::string& task, int demos, const std::vector<std::string>& freeze,
                      double module_lr_scale) {
  if (const std::string init = request["init"].value("run", ""); !init.empty())
    throw std::invalid_argument("the source started from another run (init.run " + init +
                                "), whose modules may have seen " + task +
                                ": transfer from a run trained from scratch");
  request["data"]["tasks"] = {task};
  request["data"]["holdout"] = Json::array();
  request["data"]["task_demos"] = {{task, demos}};
  request["train"]["freeze"] = freeze;
  request["train"]["lr_scale"] = Json::object();
  if (module_lr_scale != 1.0) request["train"]["lr_scale"]["modules"] = module_lr_scale;
  request["train"]["validation_tasks"] = Json::array();
  request["eval"]["tasks"] = Json::array();
  request["maps"]["selector_losses"]["explore"] = 0.0;
  return request;
}

Json to_json(const RunConfig& c) {
  Json losses = Json::object();
  for (const auto& [name, weight] : c.maps.selector_losses) losses[name] = weight;
  Json lr_scale = Json::object();
  for (const auto& [prefix, factor] : c.train.lr_scale) lr_scale[prefix] = factor;
  Json task_demos = Json::object();
  for (const auto& [name, count] : c.data.task_demos) task_demos[name] = count;
  Json out{{"method", c.method},
           {"seed", c.seed},
           {"data",
            {{"file", c.data_file},
             {"demos_per_task", c.data.demos_per_task},
             {"subsample", c.data.subsample},
             {"tasks", c.data.tasks},
             {"holdout", c.data.holdout},
             {"task_demos", task_demos},
             {"draws", c.data.draws}}},
           {"train",
            {{"steps", c.train.steps},
             {"learning_rate", c.train.learning_rate},
             {"states_per_task", c.train.states_per_task},
             {"validate_every", c.train.validate_every},
             {"checkpoint_every", c.train.checkpoint_every},
             {"validation_states_per_task", c.train.validation_states_per_task},
             {"keep_every", c.train.keep_every},
             {"bc_loss", c.train.bc_loss},
             {"freeze", c.train.freeze},
             {"lr_scale", lr_scale},
             {"flush_denormal", c.train.flush_denormal},
             {"validation_tasks", c.train.validation_tasks},
             {"optimizer", c.train.optimizer},
             {"adam_eps", c.train.adam_eps}}},
           {"maps",
            {{"modules", c.maps.modules},
             {"module_hidden", c.maps.module_hidden},
             {"selector_hidden", c.maps.selector_hidden},
             {"activation", c.maps.activation},
             {"bc_weight", c.maps.bc_weight},
             {"selector_weight", c.maps.selector_weight},
             {"selector", c.maps.selector},
             {"observations", c.maps.observations},
             {"selector_losses", losses}}},
           {"maml",
            {{"inner_lr", c.maml.inner_lr},
             {"inner_steps", c.maml.inner_steps},
             {"first_order", c.maml.first_order},
             {"query_per_task", c.maml.query_per_task},
             {"finetune_steps", c.maml.finetune_steps},
             {"validate", c.maml.validate}}},
           {"baselines", {{"hidden", c.baseline_hidden}}},
           {"eval", {{"episodes", c.eval_episodes}, {"threads", c.eval_threads}, {"tasks", c.eval_tasks}}},
           {"init", {{"run", c.init_run}, {"checkpoint", c.init_checkpoint}}}};
  if (!c.method_options.empty()) out[c.method] = c.method_options;
  return out;
}

double policy_parameter_count(const RunConfig& config, const PolicyShape& shape) {
  const MethodOptions options{config.maps, config.maml, config.baseline_hidden, config.method_options};
  return policy_method(config.method).parameters(shape, options);
}

double maps_parameter_count(const RunConfig& config, const PolicyShape& shape) {
  return maps_parameter_count(shape, config.maps);
}

std::shared_ptr<Policy> make_policy(const RunConfig& config, const PolicyShape& shape) {
  const PolicyMethod& method = policy_method(config.method);
  const MethodOptions options{config.maps, config.maml, config.baseline_hidden, config.method_options};
  const double parameters = method.parameters(shape, options);
  if (!(parameters <= kMaxParameters))
    throw std::invalid_argument("config: this " + config.method + " policy would have about " +
                                std::to_string(static_cast<long long>(std::min(parameters, 9e18))) +
                                " parameters, more than the 1e8 this library accepts; check " + method.size_keys);
  // The initialisation's own stream of the run's seed ("init").
  ag::Generator gen(envs::splitmix64(config.seed ^ 0x696e6974ULL));
  std::shared_ptr<Policy> policy = method.make(shape, options, gen);
  if (config.train.bc_loss == "sampled") policy->use_sampled_bc_loss();
  return policy;
}

}  // namespace maps::core
