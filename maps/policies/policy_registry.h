#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "io/config_schema.h"
#include "io/registry.h"
#include "maps/policies/maml.h"
#include "maps/policies/maps_policy.h"
#include "maps/policies/policy.h"

// Every method the run config, the suite and `maps train --help` know, by name. A built-in method is one file pair
// under maps/policies/ whose .cpp ends with its `<name>_method()` entry, plus one line in policy_registry.cpp
// (docs/zoo.md, "Adding a method"); another is registered with MAPS_REGISTER_POLICY_METHOD, from a program's own
// file or a plugin.
namespace maps::core {

// What a method's factory gets besides the shapes.
struct MethodOptions {
  const MAPSConfig& maps;  // MAPS's settings: also the parameter budget the zoo's methods match by default
  const MAMLConfig& maml;
  const std::vector<std::int64_t>& baseline_hidden;  // config baselines.hidden
  const nlohmann::json& own;                         // the method's own section, every default filled in
};

struct PolicyMethod {
  std::string name;     // the config's "method"
  std::string summary;  // one line: `maps train --help`, docs/configs.md
  // The method's own config section, named after it ({"moore": {...}}): each key with its type, range, default and
  // meaning (io::integer_option and its kin; the key without the method's name). Empty: no section of its own.
  std::vector<io::Field> options;
  // Checks across keys on the filled-in section (top_k at most experts); throws naming the key
  // ("config top_k_moe.top_k: ..."). Each key's own type and range are the options' to check.
  std::function<void(const nlohmann::json& own)> check;
  // The section with every key at its default ({} for a method without one).
  nlohmann::json defaults() const;
  // The parameter count for these shapes, computed before anything is allocated (a typo of 12E8 is refused
  // instead of reaching the allocator).
  std::function<double(const PolicyShape&, const MethodOptions&)> parameters;
  // The keys that set its size, for the error when it is too big.
  std::string size_keys;
  // Whether config baselines.hidden sizes it (otherwise a non-default baselines.hidden is refused as a mistake).
  bool uses_baselines_hidden = false;
  // Whether train.bc_loss "sampled" applies (MAML's inner steps use the mean's squared error).
  bool sampled_bc_loss = true;
  // Why imitation "gail" cannot train it ("" when it can): GAIL's PPO needs act() to be the mean of a Gaussian
  // policy over one step's action, trained by that Gaussian's probability ratio.
  std::string not_trained_by_gail;
  // A method that predicts action chunks by its own design (Diffusion Policy): its chunks from its filled-in section.
  // Empty: the run's chunking.* applies (one action per step by default). make() gets the shape with the output
  // widened to horizon x the action size either way.
  std::function<chunking::ActionChunking(const nlohmann::json& own)> own_chunking;
  // A choice among the options whose value changes the cost of a step or an episode by more than the size does
  // (Diffusion Policy's denoiser): `maps suite calibrate` times every choice apart and a plan prices a cell at its
  // own. Empty: one cost for the method.
  std::string cost_option;
  // An evaluation step's work relative to one policy call on the filled-in section (Diffusion Policy: its sampling
  // steps over the actions executed per chunk): a plan scales the calibrated episode cost by the cell's work over the
  // calibrated run's. Empty: the same work whatever the section.
  std::function<double(const nlohmann::json& own)> evaluation_work;
  std::function<std::shared_ptr<Policy>(const PolicyShape&, const MethodOptions&, ag::Generator&)> make;
};

// Every method: the built-ins in the order help, docs and tables list them, then the registered ones.
const std::deque<PolicyMethod>& policy_methods();
// Adds a method (io::Registry::add: a plain name not taken, else std::invalid_argument naming it and the taker).
void register_policy_method(PolicyMethod method);
// Where a method comes from: "" for the built-ins and the program's own, else the plugin's path.
std::string policy_method_origin(const std::string& name);
// The entry of a name; an unknown name is an error listing the known ones.
const PolicyMethod& policy_method(const std::string& name);
// "maps, single_bc, ...".
std::string policy_method_list();
// {"maps", "single_bc", ...}.
std::vector<std::string> policy_method_names();

// Each method's entry (at the end of its own .cpp).
PolicyMethod maps_method();
PolicyMethod single_bc_method();
PolicyMethod mt_bc_method();
PolicyMethod mt_mh_bc_method();
PolicyMethod maml_method();
PolicyMethod moore_method();
PolicyMethod paco_method();
PolicyMethod care_method();
PolicyMethod top_k_moe_method();
PolicyMethod soft_modularization_method();
PolicyMethod diffusion_policy_method();

// Parameters of an MLP with these layer sizes (weights and biases), for the entries' counts.
double mlp_parameter_count(const std::vector<std::int64_t>& sizes);
// MAPS's parameter count for these shapes and settings (the budget the zoo's methods are scaled to).
double maps_parameter_count(const PolicyShape& shape, const MAPSConfig& config);
// The width whose count(width) is nearest `target` (count grows with the width), in [1, 65536]: how the zoo's
// methods keep the paper's shape at MAPS's parameter count.
std::int64_t matched_width(double target, const std::function<double(std::int64_t)>& count);
// An own-section integer as int64 ("width": 0 means matched to MAPS).
std::int64_t option_int(const nlohmann::json& own, const char* key);

// The config with its width member chosen by matched_width for MAPS's parameter count when it is 0 (the default).
template <typename Config>
Config with_matched_width(Config config, std::int64_t Config::*width, const PolicyShape& shape,
                          const MethodOptions& options, double (*count)(const PolicyShape&, const Config&)) {
  if (config.*width != 0) return config;
  config.*width = matched_width(maps_parameter_count(shape, options.maps), [&](std::int64_t candidate) {
    Config sized = config;
    sized.*width = candidate;
    return count(shape, sized);
  });
  return config;
}

}  // namespace maps::core

// Registers a method while the program or plugin starts, at namespace scope of one .cpp:
//   MAPS_REGISTER_POLICY_METHOD(my_method());   // a function returning its maps::core::PolicyMethod
// A refused name (taken, or not plain) is recorded and reported by the plugin loader or the registry's first use.
#define MAPS_REGISTER_POLICY_METHOD(ENTRY) MAPS_REGISTRATION_(::maps::core::register_policy_method(ENTRY))
