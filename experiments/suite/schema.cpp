#include "experiments/suite/schema.h"

#include <stdexcept>

#include "maps/policies/policy_registry.h"

namespace maps::experiments {
namespace {

using io::ValueKind;

constexpr long double kMaxCount = 1000000;  // demonstrations, subsampling strides

io::Field make(std::string key, ValueKind kind, std::string type_name, std::string meaning) {
  io::Field f;
  f.key = std::move(key);
  f.kind = kind;
  f.type_name = std::move(type_name);
  f.meaning = std::move(meaning);
  return f;
}

io::Field counts(std::string key, std::string type_name, std::string meaning) {
  io::Field f = make(std::move(key), ValueKind::kIntegerList, std::move(type_name), std::move(meaning));
  f.min = 1;
  f.max = kMaxCount;
  f.non_empty = true;
  f.unique = true;
  return f;
}

io::Field count(std::string key, std::string meaning) {
  io::Field f = make(std::move(key), ValueKind::kInteger, "int", std::move(meaning));
  f.min = 1;
  f.max = kMaxCount;
  return f;
}

io::Field names(std::string key, std::string meaning) {
  io::Field f = make(std::move(key), ValueKind::kStringList, "string list", std::move(meaning));
  f.non_empty = true;
  return f;
}

std::vector<io::Field> make_schema() {
  std::vector<io::Field> s;
  s.push_back(make("description", ValueKind::kString, "string", "what the suite is for (the report's first line)"));
  s.back().default_value = "";
  s.push_back(make("plugins", ValueKind::kStringList, "string list",
                   "C++ plugins whose selector losses and methods the suite's cells name (docs/extending.md), loaded "
                   "before the rest is read; a relative path is relative to the suite config's folder. Every cell's "
                   "run config gets them as absolute paths (named here only, not in `defaults`, a set or a variant)"));
  s.back().default_value = nlohmann::json::array();
  s.back().unique = true;
  s.push_back(make("defaults", ValueKind::kObject, "partial run config",
                   "run-config keys every cell starts from (docs/configs.md; every cell's run config is checked when "
                   "the suite is read)"));
  s.back().default_value = nlohmann::json::object();
  s.push_back(make("sets.<set>.data.file", ValueKind::kString, "string",
                   "the set's demo file (`maps suite run` collects it when missing)"));
  s.back().non_empty = true;
  s.back().required = true;
  s.push_back(count("sets.<set>.data.collect_demos", "demonstrations per task to collect when the file is missing"));
  s.back().default_value = 35;
  s.push_back(count("sets.<set>.data.subsample", "the set's `data.subsample` (keep every k-th state-action pair)"));
  s.back().default_value = 1;
  s.push_back(
      counts("sets.<set>.demos", "int list",
             "the set's demonstration counts per task, for grids that name none (none: every grid names its own)"));
  s.push_back(make("sets.<set>.config", ValueKind::kObject, "partial run config",
                   "run-config keys of the set's cells, over `defaults`"));
  s.back().default_value = nlohmann::json::object();
  s.push_back(make("variants.<variant>", ValueKind::kObject, "partial run config",
                   "a named change of the run config (lower-case letters, digits and _; not `base`, the run "
                   "without one)"));
  s.back().default_value = nlohmann::json::object();
  s.push_back(io::choice_option(
      "report.holm", "variant", {"variant", "set"},
      "the families `maps report` adjusts the paired differences from MAPS within (Holm): `variant`, the comparisons "
      "made under one variant (a variant that asks its own question, such as a control); `set`, every row of a "
      "set's paired differences from MAPS (MAPS's own variants stay in their table's families), for a suite whose "
      "variants are methods of their own (experiments/suites/zoo-modern.json); `set` also draws every variant (but "
      "keep-only ones) as a line of its own in Fig. 2 and a bar group in the per-task bars, and gives each variant "
      "that routes a row in the routing tables and a panel in the routing figure"));
  s.push_back(make("report.compare", ValueKind::kStringList, "string list",
                   "comparisons `maps report` makes directly, beside those with MAPS: each \"A - B\", A and B a row "
                   "of the report (a method, or `method (variant)`, each of some cell of the suite), e.g. "
                   "\"diffusion_policy (dp_maps_h16) - diffusion_policy (dp_mlp_h16)\": A - B paired by seed at every "
                   "set, demos and k both ran, Holm over a set's rows, and the probability of improvement"));
  s.back().default_value = nlohmann::json::array();
  s.back().unique = true;
  s.push_back(make("report.last_step_base", ValueKind::kString, "string",
                   "where the suite folder holds `maps eval --last` files of its cells in `last-checkpoint/`, the "
                   "method each row of `maps report`'s last_step.md (the last training step against the "
                   "best-validation checkpoint) is paired with by seed, or `none`: no pairing, every method's cells "
                   "may be evaluated"));
  s.back().default_value = "maps";
  s.back().non_empty = true;
  s.push_back(make("report.last_step_against", ValueKind::kStringList, "string list",
                   "[SUITE, VARIANT] or []: last_step.md also pairs each row by seed with the cells of VARIANT in the "
                   "suite folder SUITE (relative to this suite's folder), at both checkpoint rules (GAIL's cells "
                   "against BC's: experiments/suites/adversarial-bc-last.json)"));
  s.back().default_value = nlohmann::json::array();
  s.push_back(make("grids[].name", ValueKind::kString, "string",
                   "the grid's name (lower-case letters, digits and _; unique in the suite)"));
  s.back().non_empty = true;
  s.back().required = true;
  s.push_back(names("grids[].sets", "the sets of its cells (each defined under `sets`)"));
  s.back().required = true;
  s.back().unique = true;
  s.push_back(names("grids[].methods", "the methods of its cells: a registered method, or `transfer`"));
  s.back().required = true;
  s.back().unique = true;
  s.back().choices = core::policy_method_names();
  s.back().choices.push_back("transfer");
  s.push_back(names("grids[].variants", "the variants of its cells (`base` or one under `variants`)"));
  s.back().default_value = nlohmann::json::array({"base"});
  s.back().unique = true;
  s.push_back(counts("grids[].demos", "int list, or object set: int list",
                     "demonstration counts per task (an object gives each set its own; default: the set's `demos`)"));
  s.push_back(make("grids[].seeds", ValueKind::kIntegerList, "uint64 list", "the seeds of its cells"));
  s.back().min = 0;
  s.back().max = io::kMaxUint64;
  s.back().non_empty = true;
  s.back().unique = true;
  s.back().required = true;
  s.push_back(names("grids[].holdout", "tasks left out of training, a cell each (variant `without-<T>`)"));
  s.back().unique = true;
  s.push_back(names("grids[].new_task",
                    "tasks taught from the grid's counts while the others train at `others_demos` (variant "
                    "`new-<T>`)"));
  s.back().unique = true;
  s.push_back(count("grids[].others_demos", "with `new_task`: the other tasks' demonstrations per task"));
  s.push_back(make("grids[].freeze", ValueKind::kStringList, "string list",
                   "with method `transfer`: the source's parameter groups kept as they are (as `maps transfer "
                   "--freeze`; the selector always learns the new task)"));
  s.back().choices = {"modules", "head"};
  s.back().unique = true;
  s.back().default_value = nlohmann::json::array({"modules"});
  s.push_back(make("grids[].module_lr_scale", ValueKind::kNumber, "float",
                   "with method `transfer`: the modules' learning-rate factor when they are fine-tuned (0: frozen "
                   "in effect; `freeze` must leave the modules out)"));
  s.back().min = 0;
  s.back().max = 1e6;
  s.back().default_value = 1.0;
  s.push_back(make("grids[].source_variant", ValueKind::kString, "string",
                   "with method `transfer`: the variant of the holdout cells it starts from (default: its own)"));
  s.back().non_empty = true;
  return s;
}

}  // namespace

const std::vector<io::Field>& suite_config_schema() {
  static const std::vector<io::Field> schema = make_schema();
  return schema;
}

io::Field suite_field(const std::string& key) {
  for (const io::Field& f : suite_config_schema())
    if (f.key == key) {
      if (key != "grids[].methods") return f;
      io::Field methods = f;  // a plugin's methods are registered after the table was made
      methods.choices = core::policy_method_names();
      methods.choices.push_back("transfer");
      return methods;
    }
  throw std::logic_error("suite_field: no key '" + key + "' in the suite config schema");
}

}  // namespace maps::experiments
