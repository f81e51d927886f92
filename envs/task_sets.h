#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "envs/env.h"
#include "envs/task_expert.h"
#include "io/registry.h"

// Task sets by name. Each task has a stable name ("gravity/0.5", "modified/big_foot") and an index
// within its set, which is the one-hot task id. Adding a task is one line in task_sets.cpp; a set of tasks from
// outside the tree (a plugin's, docs/extending.md) registers itself with MAPS_REGISTER_TASK_SET.
namespace maps::envs {

using EnvFactory = std::function<std::unique_ptr<Env>(const std::string& name, std::int64_t index)>;

struct TaskDefinition {
  std::string name;  // "<set>/<task>"
  EnvFactory make;
  // The task's expert, for demonstrations (`maps collect`); none: the expert file <experts dir>/<task>.json.
  std::function<TaskExpert()> expert = {};
};

struct TaskSetDefinition {
  std::string name;
  std::vector<TaskDefinition> tasks;  // in index order
  // How a run on the set is scored: by success rate (MT10; demonstrations must succeed) or by return over the
  // expert demonstrations' mean return (the cheetah sets).
  bool scored_by_success = false;
};

// Adds a set (io::Registry::add: a plain name not taken, else std::invalid_argument naming both). Its tasks must
// be named "<set>/<task>", be at least one, differ from each other, and each have an env factory.
void register_task_set(TaskSetDefinition set);
// Where a set comes from: "" for the built-ins and the program's own, else the plugin's path.
std::string task_set_origin(const std::string& task_set);
// Whether runs on the set are scored by success rate (MT10) rather than by normalised return.
bool scored_by_success(const std::string& task_set);
// The expert a registered set gives for its task, or an empty function (the task's expert file is its expert).
std::function<TaskExpert()> registered_expert(const std::string& task);

// {"gravity", "modified", "mt10"}, then the registered sets.
std::vector<std::string> task_set_names();
// The tasks of a set in index order; an unknown set is an error listing the valid ones.
std::vector<std::string> task_names(const std::string& task_set);
// The set a task belongs to and its index there; an unknown task is an error listing valid names.
std::string task_set_of(const std::string& task);
std::int64_t task_index(const std::string& task);
// A new environment for the task; an unknown task is an error listing the valid names.
std::unique_ptr<Env> make_env(const std::string& task);

}  // namespace maps::envs

// Registers a task set while the program or plugin starts, at namespace scope of one .cpp:
//   MAPS_REGISTER_TASK_SET(my_task_set());   // a function returning its maps::envs::TaskSetDefinition
#define MAPS_REGISTER_TASK_SET(ENTRY) MAPS_REGISTRATION_(::maps::envs::register_task_set(ENTRY))
