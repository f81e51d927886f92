#pragma once

#include <string>
#include <vector>

#include "maps/policies/policy.h"

// Transfer (docs/transfer.md): a policy for some tasks starts from a policy trained on others.
namespace maps::core {

// Copies every parameter of `source` into the parameter of the same name of `target`. Parameters of equal shape
// are copied as they are. A task-input layer, a weight [H, S + K] that reads [state, one-hot task] (MAPS's
// selector, MT-BC's first layer) and differs only in K, gets the source's state columns and, for each target task,
// the source's column of the task of that name, or the mean of the source's task columns for a task the source
// never saw (a new task starts as the average of the known ones). Anything else that differs is an error naming
// the parameter and both shapes; so is a parameter of one policy that the other lacks.
void initialize_from(Policy& target, const std::vector<std::string>& target_tasks, const Policy& source,
                     const std::vector<std::string>& source_tasks);

}  // namespace maps::core
