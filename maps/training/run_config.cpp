#include "maps/training/run_config.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <type_traits>

#include "envs/portable_random.h"
#include "io/config_schema.h"
#include "maps/selector/selector_loss.h"
#include "maps/training/run_config_fields.h"

namespace maps::core {
namespace {

using Json = nlohmann::json;

void check_keys(const Json& json, const std::string& where, const std::set<std::string>& known) {
  if (!json.is_object())
    throw std::invalid_argument((where.empty() ? "config" : "config " + where) + ": expected a JSON object, got " +
                                json.dump().substr(0, 80));
  for (const auto& [key, value] : json.items()) {
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw std::invalid_argument((where.empty() ? "config" : "config " + where) + ": unknown key '" + key +
                                  "' (known: " + list + ")");
    }
  }
}

// Far above any model the paper or this library trains (MAPS at M = 20: about 0.8M); a bigger request is a typo
// (a size of 12E8) that would otherwise fail deep inside an allocation.
constexpr double kMaxParameters = 1e8;

// A registered method's own section: known keys, each option's type and range, then the method's checks across
// keys.
Json read_method_section(const PolicyMethod& method, const Json& given) {
  std::set<std::string> known;
  for (const io::Field& option : method.options) known.insert(option.key);
  check_keys(given, method.name, known);
  Json filled = method.defaults();
  for (const io::Field& option : method.options) {
    if (!given.contains(option.key)) continue;
    io::check_value(option, given.at(option.key), "config " + method.name + ".");
    filled[option.key] = given.at(option.key);
  }
  if (method.check) method.check(filled);
  return filled;
}

// What no single key's range can say: keys that contradict each other or the method.
// Keys of one objective set under the other would do nothing: refused by name.
void check_imitation_keys(const RunConfig& c) {
  if (c.imitation == "bc") {
    for (const RunConfigField& field : run_config_fields())
      if (field.spec.key.rfind("gail.", 0) == 0 && field.get(c) != field.spec.default_value)
        throw std::invalid_argument("config " + field.spec.key +
                                    ": set, but imitation is \"bc\" (set \"imitation\": "
                                    "\"gail\" to train adversarially)");
    return;
  }
  const TrainConfig defaults;
  const auto refuse = [](const std::string& key, const std::string& why) {
    throw std::invalid_argument("config train." + key + ": " + why + " under imitation \"gail\"");
  };
  if (c.train.optimizer != defaults.optimizer) refuse("optimizer", "\"alternating\" is a BC step; not available");
  if (c.train.precision != defaults.precision)
    refuse("precision", "bf16 products are BC training's only; not available");
  if (!c.train.freeze.empty()) refuse("freeze", "not available");
  if (!c.train.lr_scale.empty()) refuse("lr_scale", "not available");
  if (c.train.keep_every != defaults.keep_every)
    refuse("keep_every", "not available (gail.checkpoint chooses best.ckpt)");
  if (c.train.ema_power != defaults.ema_power) refuse("ema_power", "not available (PPO's policy keeps no average)");
  if (!c.train.validation_tasks.empty())
    refuse("validation_tasks", "not available (GAIL's validation BC error is of every task)");
  // The trainer's own checks, here so that a config it would refuse never starts a run folder.
  adversarial::check_gail_config(gail_config_of(c));
}

void check_across_keys(const RunConfig& c, const PolicyMethod& chosen) {
  if (c.train.ema_power == 0.0 && c.train.ema_max_decay != TrainConfig{}.ema_max_decay)
    throw std::invalid_argument(
        "config train.ema_max_decay: set, but train.ema_power is 0 (no average), so it would do nothing");
  for (const auto& [name, count] : c.data.task_demos) {
    const bool held_out = std::find(c.data.holdout.begin(), c.data.holdout.end(), name) != c.data.holdout.end();
    const bool left_out =
        !c.data.tasks.empty() && std::find(c.data.tasks.begin(), c.data.tasks.end(), name) == c.data.tasks.end();
    if (held_out || left_out)
      throw std::invalid_argument("config data.task_demos." + name + ": the task is not trained (" +
                                  (held_out ? "it is in data.holdout" : "data.tasks leaves it out") +
                                  "), so its count would do nothing");
  }
  for (const auto& [prefix, factor] : c.train.lr_scale)
    for (const auto& frozen : c.train.freeze)
      if (prefix.rfind(frozen, 0) == 0)  // every parameter under the prefix is frozen
        throw std::invalid_argument("config train.lr_scale." + prefix +
                                    ": parameters under it are frozen (train.freeze \"" + frozen +
                                    "\"), so their learning rate does nothing");
  if (c.train.bc_loss == "sampled" && !chosen.sampled_bc_loss)
    throw std::invalid_argument("config train.bc_loss: \"sampled\" is not available for " + c.method +
                                " (its inner and fine-tuning steps use the mean's squared error); use \"mean\"");
  if (!chosen.uses_baselines_hidden && c.baseline_hidden != detail::default_hidden_sizes())
    throw std::invalid_argument("config baselines.hidden: " + c.method + " has no baseline MLP (its sizes are " +
                                chosen.size_keys + ")");
  check_imitation_keys(c);
  if (c.init_checkpoint.find('/') != std::string::npos || c.init_checkpoint == "." || c.init_checkpoint == "..")
    throw std::invalid_argument(
        "config init.checkpoint: expected a file name of the run folder (best.ckpt, step_<N>.ckpt), got \"" +
        c.init_checkpoint + "\"");
}

// The run config's top-level keys and each section's keys, from the table of keys (computed once).
struct Layout {
  std::set<std::string> top_keys;
  std::map<std::string, std::set<std::string>> sections;
};
const Layout& layout() {
  static const Layout cached = [] {
    Layout l;
    for (const RunConfigField& field : run_config_fields()) {
      const std::string& key = field.spec.key;
      const std::size_t dot = key.find('.');
      l.top_keys.insert(key.substr(0, dot));
      if (dot != std::string::npos) l.sections[key.substr(0, dot)].insert(key.substr(dot + 1));
    }
    return l;
  }();
  return cached;
}

// The top-level keys: the fields' sections and every method's own section (methods may be registered after the
// first config is read: a plugin's, loaded for the config that names it).
std::set<std::string> top_keys() {
  std::set<std::string> keys = layout().top_keys;
  for (const auto& method : policy_methods())
    if (!method.options.empty()) keys.insert(method.name);
  return keys;
}

}  // namespace

RunConfig parse_run_config(const Json& json) {
  RunConfig c;
  check_keys(json, "", top_keys());
  for (const auto& [section, keys] : layout().sections)
    if (json.contains(section)) check_keys(json.at(section), section, keys);
  if (!json.contains("data")) throw std::invalid_argument("config: \"data\": {\"file\": ...} is required");
  for (const RunConfigField& field : run_config_fields()) {
    const Json* value = io::find_key(json, field.spec.key);
    if (!value) {
      if (field.spec.required)
        throw std::invalid_argument("config " + field.spec.key + ": required (" + io::expectation(field.spec) + ")");
      continue;
    }
    io::check_value(field.current_spec(), *value);
    field.set(c, *value);
  }
  const PolicyMethod& chosen = policy_method(c.method);
  for (const auto& method : policy_methods()) {
    // Every registered section present is checked (a typo in another method's section is still a typo).
    if (!method.options.empty() && json.contains(method.name)) {
      Json filled = read_method_section(method, json.at(method.name));
      if (method.name == c.method) c.method_options = std::move(filled);
    }
  }
  if (!chosen.options.empty() && !json.contains(c.method)) c.method_options = chosen.defaults();
  // Named losses must exist now, not when MAPS is built (--print-config showed a misspelled one as if it were fine).
  for (const auto& [name, weight] : c.maps.selector_losses) {
    bool known = false;
    for (const auto& loss : selector_losses()) known = known || loss.name == name;
    if (!known)
      throw std::invalid_argument("config maps.selector_losses: unknown selector loss '" + name +
                                  "'; known: " + selector_loss_names());
  }
  // Before the chunk checks: a method GAIL cannot train is the reason, not its chunks.
  if (c.imitation == "gail" && !chosen.not_trained_by_gail.empty())
    throw std::invalid_argument("config imitation: \"gail\" trains a Gaussian policy by PPO; " + c.method + ": " +
                                chosen.not_trained_by_gail + " (use imitation \"bc\" for " + c.method + ")");
  chunking::check_action_chunking(c.chunking, "chunking");
  if (chosen.own_chunking && c.chunking != chunking::ActionChunking{})
    throw std::invalid_argument("config chunking: " + c.method +
                                " predicts chunks of its own; set them in its "
                                "section (\"" +
                                c.method + "\": {\"horizon\": ...}), not in chunking.*");
  c.data.action_horizon = action_chunking(c).horizon;
  if (c.imitation == "gail" && c.data.action_horizon > 1)
    throw std::invalid_argument("config chunking.horizon: GAIL's PPO acts one step at a time; action chunks (horizon " +
                                std::to_string(c.data.action_horizon) + ") are for imitation \"bc\"");
  // MAPS on raw inputs rebuilds them from the standardised ones (z std + mean): from clamped ones it would not see
  // the raw observations its option promises.
  if (c.method == "maps" && c.maps.observations == "raw_clipped" && c.data.observation_clip > 0.0)
    throw std::invalid_argument(
        "config data.observation_clip: maps.observations \"raw_clipped\" gives MAPS the raw observations (clamped "
        "to +-5 in its modules), so it cannot take clamped standardised ones too (use one or the other)");
  c.data.seed = c.seed;
  c.train.seed = c.seed;
  c.maml.finetune_seed = c.seed;
  check_across_keys(c, chosen);
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
  Json out = Json::object();
  for (const RunConfigField& field : run_config_fields()) out[io::key_pointer(field.spec.key)] = field.get(c);
  if (!c.method_options.empty()) out[c.method] = c.method_options;
  return out;
}

adversarial::GailConfig gail_config_of(const RunConfig& config) {
  adversarial::GailConfig gail = config.gail;
  gail.validation_states_per_task = config.train.validation_states_per_task;
  return gail;
}

chunking::ActionChunking action_chunking(const RunConfig& config) {
  const PolicyMethod& method = policy_method(config.method);
  if (!method.own_chunking) return config.chunking;
  chunking::ActionChunking own = method.own_chunking(config.method_options);
  chunking::check_action_chunking(own, config.method);
  return own;
}

namespace {

// The shape a method is built for: its output one chunk wide.
PolicyShape chunked_shape(const RunConfig& config, PolicyShape shape) {
  shape.action_size *= action_chunking(config).horizon;
  return shape;
}

}  // namespace

double policy_parameter_count(const RunConfig& config, const PolicyShape& step_shape) {
  const MethodOptions options{config.maps, config.maml, config.baseline_hidden, config.method_options};
  return policy_method(config.method).parameters(chunked_shape(config, step_shape), options);
}

double maps_parameter_count(const RunConfig& config, const PolicyShape& step_shape) {
  // MAPS as this config would run it: chunks from chunking.*, not from a method's own (Diffusion Policy is matched
  // to MAPS at one action per step, the study's).
  PolicyShape shape = step_shape;
  shape.action_size *= config.chunking.horizon;
  return maps_parameter_count(shape, config.maps);
}

std::shared_ptr<Policy> make_policy(const RunConfig& config, const PolicyShape& step_shape) {
  const PolicyShape shape = chunked_shape(config, step_shape);
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
  const chunking::ActionChunking chunks = action_chunking(config);
  if (chunks.chunked() || chunks.previous_observation) policy->set_chunking(chunks, step_shape.action_size);
  if (config.train.bc_loss == "sampled") policy->use_sampled_bc_loss();
  return policy;
}

}  // namespace maps::core
