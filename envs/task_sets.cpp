#include "envs/task_sets.h"

#include <functional>
#include <map>
#include <stdexcept>
#include <utility>

#include "envs/half_cheetah.h"
#include "envs/mt10/tasks.h"

namespace maps::envs {
namespace {

using EnvFactory = std::function<std::unique_ptr<Env>(const std::string& name, std::int64_t index)>;

struct TaskDefinition {
  std::string name;
  EnvFactory make;
};

struct TaskSet {
  std::string name;
  std::vector<TaskDefinition> tasks;  // in index order
};

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

const std::vector<TaskSet>& registry() {
  static const std::vector<TaskSet> sets = {
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
      {"mt10", mt10_definitions()},
  };
  return sets;
}

std::string all_task_names() {
  std::string names;
  for (const auto& set : registry()) {
    for (const auto& task : set.tasks) {
      if (!names.empty()) names += ", ";
      names += task.name;
    }
  }
  return names;
}

struct Found {
  const TaskSet* set;
  std::int64_t index;
};

Found find_task(const std::string& task) {
  for (const auto& set : registry()) {
    for (std::size_t i = 0; i < set.tasks.size(); ++i) {
      if (set.tasks[i].name == task) return {&set, static_cast<std::int64_t>(i)};
    }
  }
  throw std::invalid_argument("unknown task '" + task + "'; valid tasks: " + all_task_names());
}

}  // namespace

std::vector<std::string> task_set_names() {
  std::vector<std::string> names;
  for (const auto& set : registry()) names.push_back(set.name);
  return names;
}

std::vector<std::string> task_names(const std::string& task_set) {
  std::string valid;
  for (const auto& set : registry()) {
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
