#include "experiments/suite/config.h"

#include <algorithm>
#include <optional>
#include <regex>
#include <set>
#include <stdexcept>

#include "envs/task_sets.h"
#include "experiments/process/plugins.h"
#include "experiments/run/run_folder.h"
#include "experiments/suite/schema.h"
#include "io/config_schema.h"
#include "maps/training/run_config.h"

namespace maps::experiments {
namespace {

using Json = nlohmann::json;

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& name : names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

void check_keys(const Json& json, const std::string& where, const std::vector<std::string>& known) {
  if (!json.is_object()) throw std::invalid_argument(where + ": expected a JSON object, got " + json.dump());
  for (const auto& [key, value] : json.items())
    if (std::find(known.begin(), known.end(), key) == known.end())
      throw std::invalid_argument(where + ": unknown key '" + key + "' (known: " + joined(known) + ")");
}

const Json& required(const Json& json, const std::string& where, const std::string& key) {
  if (!json.contains(key)) throw std::invalid_argument(where + ": \"" + key + "\" is required");
  return json.at(key);
}

// `value`, found at `path` of the suite config, checked against the schema's field `key` ("grids[].seeds").
const Json& checked(const Json& value, const std::string& key, const std::string& path) {
  io::Field field = suite_field(key);
  field.key = path;
  io::check_value(field, value, "");
  return value;
}

bool is_keep_only(const std::string& variant) { return std::regex_match(variant, std::regex("keep[0-9]+")); }

// The report's name of a cell's row: "maps", "diffusion_policy (dp_mlp_h16)" (experiments/report/suite_results.py); a
// keep-only variant (train.keep_every alone) where its setting has no base cells stands for the base, as there.
std::string row_label(const SuiteCell& cell, const std::set<std::string>& base_settings) {
  if (cell.variant == "base") return cell.method;
  if (is_keep_only(cell.variant) &&
      !base_settings.count(cell.set + "/" + cell.method + "/" + std::to_string(cell.demos)))
    return cell.method;
  return cell.method + " (" + cell.variant + ")";
}

// report.compare: each "A - B" names two different rows of the suite that share a set and count, once (not again as
// "B - A": the same test twice in a Holm family), so that a typo fails at plan time rather than leaving the report's
// table empty.
void check_comparisons(const Json& compare, const std::vector<SuiteCell>& cells, const std::string& where) {
  std::set<std::string> base_settings;
  for (const auto& cell : cells)
    if (cell.variant == "base") base_settings.insert(cell.set + "/" + cell.method + "/" + std::to_string(cell.demos));
  std::map<std::string, std::set<std::string>> rows;  // row -> "set/demos/k" it ran at
  for (const auto& cell : cells)
    rows[row_label(cell, base_settings)].insert(cell.set + "/" + std::to_string(cell.demos) + "/" +
                                                std::to_string(cell.subsample));
  std::string known;
  for (const auto& [row, settings] : rows) known += (known.empty() ? "" : ", ") + row;
  std::set<std::pair<std::string, std::string>> seen;
  for (std::size_t i = 0; i < compare.size(); ++i) {
    const std::string at = where + "[" + std::to_string(i) + "]", text = compare[i].get<std::string>();
    const std::size_t split = text.find(" - ");
    if (split == std::string::npos || text.find(" - ", split + 1) != std::string::npos)
      throw std::invalid_argument(at + ": expected \"A - B\" (two rows of the report joined by \" - \"), got \"" +
                                  text + "\"");
    const std::string a = text.substr(0, split), b = text.substr(split + 3);
    for (const auto& side : {a, b})
      if (!rows.count(side))
        throw std::invalid_argument(at + ": \"" + side +
                                    "\" is no row of the suite (a method, or \"method (variant)\"," +
                                    " of one of its cells: " + known + ")");
    if (a == b) throw std::invalid_argument(at + ": expected two different rows, got \"" + a + "\" twice");
    const auto& at_a = rows.at(a);
    if (std::none_of(at_a.begin(), at_a.end(), [&](const std::string& s) { return rows.at(b).count(s) > 0; }))
      throw std::invalid_argument(at + ": \"" + a + "\" and \"" + b +
                                  "\" share no set, demonstration count and k, so there is nothing to pair");
    if (seen.count({b, a}))
      throw std::invalid_argument(at + ": \"" + text + "\" is an earlier entry reversed: the same test twice");
    seen.insert({a, b});
  }
}

bool is_plain_name(const std::string& name) {
  static const std::regex pattern("[a-z0-9][a-z0-9_]*");
  return std::regex_match(name, pattern);
}

SuiteSet parse_set(const std::string& name, const Json& json, const std::string& where) {
  if (const auto sets = envs::task_set_names(); std::find(sets.begin(), sets.end(), name) == sets.end())
    throw std::invalid_argument(where + ": '" + name + "' is not a task set (known: " + joined(sets) + ")");
  check_keys(json, where, {"data", "demos", "config"});
  SuiteSet set;
  set.name = name;
  const Json& data = required(json, where, "data");
  check_keys(data, where + ".data", {"file", "collect_demos", "subsample"});
  set.demo_file =
      checked(required(data, where + ".data", "file"), "sets.<set>.data.file", where + ".data.file").get<std::string>();
  if (data.contains("collect_demos"))
    set.collect_demos =
        checked(data["collect_demos"], "sets.<set>.data.collect_demos", where + ".data.collect_demos").get<int>();
  if (data.contains("subsample"))
    set.subsample = checked(data["subsample"], "sets.<set>.data.subsample", where + ".data.subsample").get<int>();
  if (json.contains("demos"))
    set.demos = checked(json["demos"], "sets.<set>.demos", where + ".demos").get<std::vector<int>>();
  if (json.contains("config")) set.config = checked(json["config"], "sets.<set>.config", where + ".config");
  return set;
}

std::vector<int> grid_demos(const Json& grid, const SuiteSet& set, const std::string& where) {
  if (!grid.contains("demos")) {
    if (set.demos.empty())
      throw std::invalid_argument(where + ": names no demos, and sets." + set.name + " has no \"demos\" either");
    return set.demos;
  }
  const Json& demos = grid["demos"];
  if (demos.is_array()) return checked(demos, "grids[].demos", where + ".demos").get<std::vector<int>>();
  if (!demos.is_object() || demos.empty())
    throw std::invalid_argument(where + ".demos: expected an array of counts or an object of set: counts, got " +
                                demos.dump());
  for (const auto& [key, value] : demos.items())
    if (const auto sets = envs::task_set_names(); !std::count(sets.begin(), sets.end(), key))
      throw std::invalid_argument(where + ".demos: '" + key + "' is not a task set (known: " + joined(sets) + ")");
  if (!demos.contains(set.name)) {
    if (set.demos.empty())
      throw std::invalid_argument(where + ".demos: has no counts for " + set.name + ", nor has sets." + set.name);
    return set.demos;
  }
  return checked(demos[set.name], "grids[].demos", where + ".demos." + set.name).get<std::vector<int>>();
}

// A grid's task axis: none, tasks held out of training ("holdout"), or new tasks with few demonstrations each
// ("new_task": the other tasks at "others_demos"; method "transfer" starts from the holdout cell of that task).
struct TaskAxis {
  enum class Kind { kNone, kHoldout, kNew } kind = Kind::kNone;
  std::vector<std::string> tasks{""};
  int others_demos = 0;
  std::vector<std::string> freeze{"modules"};
  double module_lr_scale = 1.0;
  // The variant of the holdout cell a transfer cell starts from (unset: the transfer cell's own variant). A grid of
  // fine-tuned transfer names its cells with a variant of its own and starts from the base holdout runs.
  std::optional<std::string> source_variant;
};

TaskAxis task_axis(const Json& grid, const std::vector<std::string>& set_names, const std::vector<std::string>& methods,
                   const std::string& at) {
  TaskAxis axis;
  const bool holdout = grid.contains("holdout"), fresh = grid.contains("new_task");
  if (holdout && fresh) throw std::invalid_argument(at + ": \"holdout\" and \"new_task\" exclude each other");
  const bool transfer = std::count(methods.begin(), methods.end(), "transfer") > 0;
  if (transfer && !fresh)
    throw std::invalid_argument(at + ": method transfer needs \"new_task\" (the tasks to teach) and \"others_demos\"");
  for (const char* key : {"others_demos", "freeze", "module_lr_scale", "source_variant"})
    if (grid.contains(key) && !fresh) throw std::invalid_argument(at + "." + key + ": only with \"new_task\"");
  for (const char* key : {"freeze", "module_lr_scale", "source_variant"})
    if (grid.contains(key) && !transfer)
      throw std::invalid_argument(at + "." + key + ": only with method transfer (it says how transfer cells train)");
  if (!holdout && !fresh) return axis;
  axis.kind = holdout ? TaskAxis::Kind::kHoldout : TaskAxis::Kind::kNew;
  const std::string key = holdout ? "holdout" : "new_task";
  axis.tasks = checked(grid[key], "grids[]." + key, at + "." + key).get<std::vector<std::string>>();
  for (const auto& task : axis.tasks) {
    bool found = false;
    for (const auto& set : set_names) {
      const auto names = envs::task_names(set);
      found = found || std::find(names.begin(), names.end(), task) != names.end();
    }
    if (!found) throw std::invalid_argument(at + "." + key + ": '" + task + "' is not a task of " + joined(set_names));
  }
  if (fresh) {
    axis.others_demos =
        checked(required(grid, at, "others_demos"), "grids[].others_demos", at + ".others_demos").get<int>();
    // The choices of `maps transfer --freeze`: a source is a MAPS run, whose groups are its modules, its head and
    // its selector, and the selector must learn the new task.
    if (grid.contains("freeze"))
      axis.freeze = checked(grid["freeze"], "grids[].freeze", at + ".freeze").get<std::vector<std::string>>();
    if (grid.contains("source_variant"))
      axis.source_variant =
          checked(grid["source_variant"], "grids[].source_variant", at + ".source_variant").get<std::string>();
    if (grid.contains("module_lr_scale")) {
      axis.module_lr_scale =
          checked(grid["module_lr_scale"], "grids[].module_lr_scale", at + ".module_lr_scale").get<double>();
      if (axis.module_lr_scale != 1.0 &&
          std::find(axis.freeze.begin(), axis.freeze.end(), "modules") != axis.freeze.end())
        throw std::invalid_argument(at + ".module_lr_scale: the modules are frozen (freeze " + joined(axis.freeze) +
                                    "); drop \"modules\" from freeze to fine-tune them");
    }
  }
  return axis;
}

// "gravity/0.5" -> "0.5": what names the task in a cell's variant.
std::string short_task(const std::string& task) { return task.substr(task.rfind('/') + 1); }

}  // namespace

Json SuiteCell::identity() const {
  return {{"index", index},     {"name", name},   {"grid", grid},           {"set", set},  {"method", method},
          {"variant", variant}, {"demos", demos}, {"subsample", subsample}, {"seed", seed}};
}

Json merge_json(Json base, const Json& more) {
  if (!base.is_object() || !more.is_object()) return more;
  for (const auto& [key, value] : more.items()) base[key] = base.contains(key) ? merge_json(base[key], value) : value;
  return base;
}

Suite parse_suite(const Json& json, const std::string& where) {
  check_keys(json, where, {"description", "plugins", "defaults", "sets", "variants", "grids", "report"});
  Suite suite;
  suite.source = json;
  if (json.contains("description")) checked(json["description"], "description", where + ".description");
  // Read by `maps report` alone (experiments/report/tables.py); checked here so that a typo fails at plan time.
  if (json.contains("report")) {
    if (!json["report"].is_object()) throw std::invalid_argument(where + ".report: expected an object");
    check_keys(json["report"], where + ".report", {"holm", "compare", "last_step_base", "last_step_against"});
    if (json["report"].contains("holm")) checked(json["report"]["holm"], "report.holm", where + ".report.holm");
    if (json["report"].contains("compare"))
      checked(json["report"]["compare"], "report.compare", where + ".report.compare");
    if (json["report"].contains("last_step_base"))
      checked(json["report"]["last_step_base"], "report.last_step_base", where + ".report.last_step_base");
    if (json["report"].contains("last_step_against")) {
      const Json& against = json["report"]["last_step_against"];
      checked(against, "report.last_step_against", where + ".report.last_step_against");
      const bool pair =
          against.size() == 2 && !against[0].get<std::string>().empty() && !against[1].get<std::string>().empty();
      if (!against.empty() && !pair)
        throw std::invalid_argument(where +
                                    ".report.last_step_against: expected [] or [SUITE, VARIANT] (two "
                                    "non-empty strings), got " +
                                    against.dump());
    }
  }
  // Loaded first: the grids may name their methods and the cells' configs their selector losses. load_suite has
  // made the paths absolute (relative to the config's folder); a JSON parsed on its own has them from the working
  // directory.
  Json plugins = Json::array();
  if (json.contains("plugins")) {
    checked(json["plugins"], "plugins", where + ".plugins");
    plugins = load_config_plugins({{"plugins", json["plugins"]}}, ".", where).at("plugins");
  }
  if (json.contains("defaults")) checked(json["defaults"], "defaults", where + ".defaults");
  const Json defaults = json.value("defaults", Json::object());
  const auto refuse_plugins_in = [&where](const Json& partial, const std::string& at) {
    if (partial.is_object() && partial.contains("plugins"))
      throw std::invalid_argument(where + at +
                                  ".plugins: a suite names its plugins at its top (\"plugins\": [...]), "
                                  "which every cell gets");
  };
  refuse_plugins_in(defaults, ".defaults");

  const Json& sets = required(json, where, "sets");
  if (!sets.is_object() || sets.empty()) throw std::invalid_argument(where + ".sets: expected an object of sets");
  for (const auto& [name, value] : sets.items()) {
    suite.sets.emplace(name, parse_set(name, value, where + ".sets." + name));
    refuse_plugins_in(suite.sets.at(name).config, ".sets." + name + ".config");
  }

  std::map<std::string, Json> variants;
  if (json.contains("variants")) {
    if (!json["variants"].is_object()) throw std::invalid_argument(where + ".variants: expected an object");
    for (const auto& [name, value] : json["variants"].items()) {
      if (!is_plain_name(name) || name == "base")
        throw std::invalid_argument(where + ".variants: '" + name +
                                    "' is not a variant name (lower-case letters, digits and _; not \"base\")");
      variants.emplace(name, checked(value, "variants.<variant>", where + ".variants." + name));
      refuse_plugins_in(value, ".variants." + name);
    }
  }

  const Json& grids = required(json, where, "grids");
  if (!grids.is_array() || grids.empty()) throw std::invalid_argument(where + ".grids: expected a non-empty array");
  std::map<std::string, std::size_t> by_name;
  std::set<std::string> grid_names;
  for (std::size_t g = 0; g < grids.size(); ++g) {
    const std::string at = where + ".grids[" + std::to_string(g) + "]";
    const Json& grid = grids[g];
    check_keys(grid, at,
               {"name", "sets", "methods", "variants", "demos", "seeds", "holdout", "new_task", "others_demos",
                "freeze", "module_lr_scale", "source_variant"});
    const Json& name_json = checked(required(grid, at, "name"), "grids[].name", at + ".name");
    if (!is_plain_name(name_json.get<std::string>()))
      throw std::invalid_argument(at + ".name: expected a name of lower-case letters, digits and _, got " +
                                  name_json.dump());
    const std::string grid_name = name_json.get<std::string>();
    if (!grid_names.insert(grid_name).second)
      throw std::invalid_argument(at + ".name: '" + grid_name + "' names two grids");
    const auto set_names =
        checked(required(grid, at, "sets"), "grids[].sets", at + ".sets").get<std::vector<std::string>>();
    for (const auto& s : set_names)
      if (!suite.sets.count(s)) throw std::invalid_argument(at + ".sets: '" + s + "' is not defined under \"sets\"");
    const auto methods =
        checked(required(grid, at, "methods"), "grids[].methods", at + ".methods").get<std::vector<std::string>>();
    const auto variant_names =
        grid.contains("variants")
            ? checked(grid["variants"], "grids[].variants", at + ".variants").get<std::vector<std::string>>()
            : std::vector<std::string>{"base"};
    for (const auto& v : variant_names)
      if (v != "base" && !variants.count(v))
        throw std::invalid_argument(at + ".variants: '" + v + "' is not defined under \"variants\"");
    const auto seeds =
        checked(required(grid, at, "seeds"), "grids[].seeds", at + ".seeds").get<std::vector<std::uint64_t>>();
    const TaskAxis axis = task_axis(grid, set_names, methods, at);
    if (axis.source_variant && *axis.source_variant != "base" && !variants.count(*axis.source_variant))
      throw std::invalid_argument(at + ".source_variant: '" + *axis.source_variant +
                                  "' is not defined under \"variants\"");

    for (const std::uint64_t seed : seeds)
      for (const auto& set_name : set_names) {
        const SuiteSet& set = suite.sets.at(set_name);
        const std::vector<int> counts = grid_demos(grid, set, at);
        const auto set_tasks = envs::task_names(set_name);
        for (const auto& task : axis.tasks) {
          if (!task.empty() && std::find(set_tasks.begin(), set_tasks.end(), task) == set_tasks.end()) continue;
          for (const auto& method : methods)
            for (const auto& variant : variant_names)
              for (const int demos : counts) {
                SuiteCell cell;
                cell.grid = grid_name;
                cell.set = set_name;
                cell.method = method;
                // The task axis shows in the variant: "without-0.5" (held out), "new-0.5" (taught from `demos`).
                const std::string task_part = axis.kind == TaskAxis::Kind::kNone      ? ""
                                              : axis.kind == TaskAxis::Kind::kHoldout ? "without-" + short_task(task)
                                                                                      : "new-" + short_task(task);
                cell.variant =
                    task_part.empty() ? variant : (variant == "base" ? task_part : variant + "-" + task_part);
                cell.demos = demos;
                cell.seed = seed;
                const std::string folder = method + (cell.variant == "base" ? "" : "-" + cell.variant) + "_d" +
                                           std::to_string(demos) + "_s" + std::to_string(seed);
                cell.name = set_name + "/" + folder;
                Json request;
                if (method == "transfer") {
                  // The MAPS cell that never saw the task, at the other tasks' count: its request, for the task alone,
                  // starting from its best checkpoint (a sibling folder), as `maps transfer` builds it.
                  const std::string& from = axis.source_variant ? *axis.source_variant : variant;
                  // A transfer cell's run config is its source's, taught the task: a variant that is not the
                  // source's can only name the cells, so a config in it would be silently dropped.
                  if (from != variant && variant != "base" && !variants.at(variant).empty())
                    throw std::invalid_argument(at + ".variants: '" + variant + "' has a run config (" +
                                                variants.at(variant).dump() + "), but transfer cells started from " +
                                                "source_variant '" + from +
                                                "' take their source's; give the grid an empty variant ({}) to name "
                                                "its cells, and say what transfer trains with freeze and "
                                                "module_lr_scale");
                  const std::string source_folder = "maps-" + (from == "base" ? "" : from + "-") + "without-" +
                                                    short_task(task) + "_d" + std::to_string(axis.others_demos) + "_s" +
                                                    std::to_string(seed);
                  const auto source = by_name.find(set_name + "/" + source_folder);
                  if (source == by_name.end())
                    throw std::invalid_argument(at + ": cell " + cell.name + " transfers from " + set_name + "/" +
                                                source_folder +
                                                ", which no earlier grid makes (a grid with method maps, holdout [\"" +
                                                task + "\"], demos [" + std::to_string(axis.others_demos) + "])");
                  try {
                    request = core::transfer_request(suite.cells[source->second].request, task, demos, axis.freeze,
                                                     axis.module_lr_scale);
                  } catch (const std::invalid_argument& e) {
                    throw std::invalid_argument(at + ": cell " + cell.name + " transfers from " + set_name + "/" +
                                                source_folder + ": " + e.what());
                  }
                  request["init"] = {{"run", "../" + source_folder}, {"checkpoint", run_files::kBestCheckpoint}};
                } else {
                  request = merge_json(defaults, set.config);
                  request = merge_json(request, {{"data", {{"file", set.demo_file}, {"subsample", set.subsample}}}});
                  if (variant != "base") request = merge_json(request, variants.at(variant));
                  request =
                      merge_json(request, {{"method", method}, {"seed", seed}, {"data", {{"demos_per_task", demos}}}});
                  if (axis.kind == TaskAxis::Kind::kHoldout) request["data"]["holdout"] = {task};
                  if (axis.kind == TaskAxis::Kind::kNew) {
                    // The new task's score is what compares: only it is evaluated. Single BC learns each task
                    // alone, so it is trained on the new task alone.
                    request["data"]["demos_per_task"] = axis.others_demos;
                    request["data"]["task_demos"] = {{task, demos}};
                    request["eval"]["tasks"] = {task};
                    request["train"]["validation_tasks"] = {task};
                    if (method == "single_bc") request["data"]["tasks"] = {task};
                  }
                }
                if (!plugins.empty()) request["plugins"] = plugins;
                try {
                  cell.request = core::to_json(core::parse_run_config(request));
                } catch (const std::exception& e) {
                  throw std::invalid_argument(at + ": cell " + cell.name + ": " + e.what());
                }
                cell.subsample = cell.request["data"]["subsample"].get<int>();
                if (const auto found = by_name.find(cell.name); found != by_name.end()) {
                  if (suite.cells[found->second].request != cell.request)
                    throw std::invalid_argument(at + ": cell " + cell.name + " is also in grid '" +
                                                suite.cells[found->second].grid +
                                                "' with another run config; give one of them a variant");
                  continue;
                }
                cell.index = static_cast<int>(suite.cells.size());
                by_name.emplace(cell.name, suite.cells.size());
                suite.cells.push_back(std::move(cell));
              }
        }
      }
  }
  if (json.contains("report") && json["report"].contains("compare"))
    check_comparisons(json["report"]["compare"], suite.cells, where + ".report.compare");
  // A cell that starts from a sibling cell (init.run "../<name>") which, through its own init.run, starts from the
  // first: neither can run before the other.
  for (const auto& cell : suite.cells) {
    std::vector<std::string> chain{cell.name};
    for (const SuiteCell* at = source_cell(suite, cell); at; at = source_cell(suite, *at)) {
      chain.push_back(at->name);
      if (std::find(chain.begin(), chain.end() - 1, at->name) != chain.end() - 1) {
        std::string path;
        for (const auto& name : chain) path += (path.empty() ? "" : " -> ") + name;
        throw std::invalid_argument(where + ": init.run goes round in a circle (" + path +
                                    "): a cell cannot start from a run that starts from it");
      }
    }
  }
  return suite;
}

Suite load_suite(const std::string& path, const std::string& precision) {
  Json json = read_json_file(path);
  if (!precision.empty()) {
    if (!json.is_object()) throw std::invalid_argument(path + ": expected a JSON object (a suite config)");
    if (json.contains("defaults") && !json["defaults"].is_object())
      throw std::invalid_argument(path + ".defaults: expected an object");
    if (json.contains("defaults") && json["defaults"].contains("train") && !json["defaults"]["train"].is_object())
      throw std::invalid_argument(path + ".defaults.train: expected an object");
    json["defaults"]["train"]["precision"] = precision;
  }
  Suite suite = parse_suite(load_config_plugins(json, folder_of(path), path), path);
  suite.path = path;
  return suite;
}

std::pair<int, int> parse_shard(const std::string& text) {
  static const std::regex pattern("([0-9]{1,6})/([0-9]{1,6})");
  std::smatch match;
  if (std::regex_match(text, match, pattern)) {
    const int shard = std::stoi(match[1]), shards = std::stoi(match[2]);
    if (shards >= 1 && shard < shards) return {shard, shards};
  }
  throw std::invalid_argument("--shard: expected i/N with 0 <= i < N (e.g. 0/4), got '" + text + "'");
}

const SuiteCell* source_cell(const Suite& suite, const SuiteCell& cell) {
  const std::string relative = cell.request.contains("init") ? cell.request["init"].value("run", "") : "";
  if (relative.rfind("../", 0) != 0) return nullptr;
  const std::string source = cell.set + "/" + relative.substr(3);
  const auto found = std::find_if(suite.cells.begin(), suite.cells.end(),
                                  [&source](const SuiteCell& other) { return other.name == source; });
  return found == suite.cells.end() ? nullptr : &*found;
}

int shard_key(const Suite& suite, const SuiteCell& cell) {
  // A transfer cell reads its source's folder, a sibling under the same shard's cells/: it goes where its source
  // goes (sources come first in the order, so the shard runs the source before its dependants). Followed at most
  // once per cell of the suite, so a cycle (a hand-edited suite.json's init.run naming its own folder) cannot loop.
  const SuiteCell* at = &cell;
  for (std::size_t hops = 0; hops < suite.cells.size(); ++hops) {
    const SuiteCell* source = source_cell(suite, *at);
    if (!source || source == at) break;
    at = source;
  }
  return at->index;
}

std::vector<const SuiteCell*> shard_cells(const Suite& suite, int shard, int shards) {
  std::vector<const SuiteCell*> out;
  for (const auto& cell : suite.cells)
    if (shard_key(suite, cell) % shards == shard) out.push_back(&cell);
  return out;
}

}  // namespace maps::experiments
