// One step's actions for a batch of running episodes of one task, as the evaluator and `maps render` both act:
// a policy acting per step is asked for every row; a policy predicting chunks is asked, in one call, for the rows
// whose episode's executor needs a chunk, and every row then acts by its executor (ACT's ensemble or open loop).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "maps/chunking/action_chunking.h"
#include "maps/policies/policy.h"

namespace maps::core {

// x, before: the rows' standardised current and previous states [n, S] (before is x itself for a policy that reads
// no history). executors: one per row, each its episode's, when policy.chunking() is chunked; empty otherwise.
// Returns the actions [n, A] (A: the env's action size). Throws, starting with `where` (the caller and the task:
// "evaluate: task 'mt10/reach'"), when the policy returns another shape or the executors do not match the rows.
ag::RowMatrixD step_actions(Policy& policy, const ag::Tensor& x, const ag::Tensor& before, std::int64_t task_id,
                            const std::vector<chunking::ChunkExecutor*>& executors, const std::string& where);

}  // namespace maps::core
