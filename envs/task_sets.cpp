#include "envs/task_sets.h"

#include <deque>
#include <functional>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

#include "envs/half_cheetah.h"
#include "envs/mt10/tasks.h"

namespace maps::envs {
namespace {

// Gravity set (gym-extensions' HalfCheetahGravity*): g scaled, the body unchanged.
EnvFactory cheetah_gravity(double scale) {
  return [scale](const std::string& name, std::int64_t index) -> std::unique_ptr<Env> {
    return std::make_unique<HalfCheetahEnv>(name, index, HalfCheetahVariant{scale, {}});
  };
}

// Modified set (gym-extensions' HalfCheetahBig*/Small*): the named geoms' sizes scaled. Thigh, leg
// (the shins) and foot change on both legs together.
EnvFactory cheetah_geoms(std::vector<std::string> geoms, double scale) {
  std::map<std::string, double> sizes;
  for (auto& geom : geoms) sizes[std::move(geom)] = scale;
  return [sizes](const std::string& name, std::int64_t index) -> std::unique_ptr<Env> {
    return std::make_unique<HalfCheetahEnv>(name, index, HalfCheetahVariant{1.0, sizes});
  };
}

// MT10 (Meta-World's ten manipulation tasks), with the default options (horizon 150).
std::vector<TaskDefinition> mt10_definitions() {
  std::vector<TaskDefinition> definitions;
  for (const mt10::MT10Task& task : mt10::mt10_tasks()) {
    const mt10::MT10Factory make = task.make;
    definitions.push_back({"mt10/" + task.name, [make](const std::string& name, std::int64_t index) {
                             return std::unique_ptr<Env>(make(name, index, mt10::MT10Options{}));
                           }});
  }
  return definitions;
}

constexpr double kBig = 1.25;
constexpr double kSmall = 0.75;

io::Registry<TaskSetDefinition>& registry() {
  static io::Registry<TaskSetDefinition> sets("task set", [] {
    return std::deque<TaskSetDefinition>{
        {"gravity",
         {
             {"gravity/0.5", cheetah_gravity(0.5)},
             {"gravity/0.75", cheetah_gravity(0.75)},
             {"gravity/1.0", cheetah_gravity(1.0)},
             {"gravity/1.25", cheetah_gravity(1.25)},
             {"gravity/1.5", cheetah_gravity(1.5)},
         }},
        {"modified",
         {
             {"modified/original", cheetah_geoms({}, 1.0)},
             {"modified/big_head", cheetah_geoms({"head"}, kBig)},
             {"modified/small_head", cheetah_geoms({"head"}, kSmall)},
             {"modified/big_torso", cheetah_geoms({"torso"}, kBig)},
             {"modified/small_torso", cheetah_geoms({"torso"}, kSmall)},
             {"modified/big_thigh", cheetah_geoms({"bthigh", "fthigh"}, kBig)},
             {"modified/small_thigh", cheetah_geoms({"bthigh", "fthigh"}, kSmall)},
             {"modified/big_leg", cheetah_geoms({"bshin", "fshin"}, kBig)},
             {"modified/small_leg", cheetah_geoms({"bshin", "fshin"}, kSmall)},
             {"modified/big_foot", cheetah_geoms({"bfoot", "ffoot"}, kBig)},
             {"modified/small_foot", cheetah_geoms({"bfoot", "ffoot"}, kSmall)},
         }},
        {"mt10", mt10_definitions(), /*scored_by_success=*/true},
    };
  });
  return sets;
}

const std::deque<TaskSetDefinition>& task_sets() { return registry().entries(); }

std::string all_task_names() {
  std::string names;
  for (const auto& set : task_sets()) {
    for (const auto& task : set.tasks) {
      if (!names.empty()) names += ", ";
      names += task.name;
    }
  }
  return names;
}

struct Found {
  const TaskSetDefinition* set;
  std::int64_t index;
};

Found find_task(const std::string& task) {
  for (const auto& set : task_sets()) {
    for (std::size_t i = 0; i < set.tasks.size(); ++i) {
      if (set.tasks[i].name == task) return {&set, static_cast<std::int64_t>(i)};
    }
  }
  throw std::invalid_argument("unknown task '" + task + "'; valid tasks: " + all_task_names());
}

}  // namespace

void register_task_set(TaskSetDefinition set) {
  const std::string where = "task set '" + set.name + "'";
  if (set.tasks.empty()) throw std::invalid_argument(where + ": it has no tasks");
  std::set<std::string> names;
  for (const TaskDefinition& task : set.tasks) {
    if (task.name.rfind(set.name + "/", 0) != 0 || task.name.size() == set.name.size() + 1)
      throw std::invalid_argument(where + ": task '" + task.name + "' is not named '" + set.name + "/<task>'");
    if (!names.insert(task.name).second) throw std::invalid_argument(where + ": task '" + task.name + "' twice");
    if (!task.make) throw std::invalid_argument(where + ": task '" + task.name + "' has no env factory");
  }
  registry().add(std::move(set));
}

std::string task_set_origin(const std::string& task_set) { return registry().origin_of(task_set); }

bool scored_by_success(const std::string& task_set) {
  for (const auto& set : task_sets())
    if (set.name == task_set) return set.scored_by_success;
  throw std::invalid_argument("unknown task set '" + task_set + "'; valid sets: " + registry().names());
}

std::function<TaskExpert()> registered_expert(const std::string& task) {
  const Found found = find_task(task);
  return found.set->tasks[static_cast<std::size_t>(found.index)].expert;
}

std::vector<std::string> task_set_names() {
  std::vector<std::string> names;
  for (const auto& set : task_sets()) names.push_back(set.name);
  return names;
}

std::vector<std::string> task_names(const std::string& task_set) {
  std::string valid;
  for (const auto& set : task_sets()) {
    if (set.name == task_set) {
      std::vector<std::string> names;
      for (const auto& task : set.tasks) names.push_back(task.name);
      return names;
    }
    if (!valid.empty()) valid += ", ";
    valid += set.name;
  }
  throw std::invalid_argument("unknown task set '" + task_set + "'; valid sets: " + valid);
}

std::string task_set_of(const std::string& task) { return find_task(task).set->name; }

std::int64_t task_index(const std::string& task) { return find_task(task).index; }

std::unique_ptr<Env> make_env(const std::string& task) {
  const Found found = find_task(task);
  const TaskDefinition& definition = found.set->tasks[static_cast<std::size_t>(found.index)];
  return definition.make(definition.name, found.index);
}

}  // namespace maps::envs
