#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "envs/env.h"

// Task sets by name. Each task has a stable name ("gravity/0.5", "modified/big_foot") and an index
// within its set, which is the one-hot task id. Adding a task is one line in task_sets.cpp.
namespace maps::envs {

// {"gravity", "modified", "mt10"}.
std::vector<std::string> task_set_names();
// The tasks of a set in index order; an unknown set is an error listing the valid ones.
std::vector<std::string> task_names(const std::string& task_set);
// The set a task belongs to and its index there; an unknown task is an error listing valid names.
std::string task_set_of(const std::string& task);
std::int64_t task_index(const std::string& task);
// A new environment for the task; an unknown task is an error listing the valid names.
std::unique_ptr<Env> make_env(const std::string& task);

}  // namespace maps::envs
