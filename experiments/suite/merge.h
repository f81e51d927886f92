#pragma once

#include <string>
#include <vector>

namespace maps::experiments {

// `maps suite merge --out DIR SHARD...`: the finished cells of shard folders of one suite, copied into DIR (each
// through a temporary folder and a rename). Two shards with different results for one cell are an error.
struct SuiteMergeOptions {
  std::string out;
  std::vector<std::string> shards;
};
int run_suite_merge(const SuiteMergeOptions& options);

}  // namespace maps::experiments
