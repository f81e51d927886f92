#pragma once

#include <string>
#include <vector>

namespace maps::experiments {

// `maps suite status DIR... [--json] [--all]`: each cell of DIR/suite.json is done (a trusted result.json), running
// (its .lock is held), failed (error.json, with the error), started (a checkpoint to resume from) or left. Several
// folders of one suite (the shard folders of a cluster run) are read as one: a cell counts as what its most
// advanced folder says (done, then running, failed, started, left).
struct SuiteStatusOptions {
  std::vector<std::string> dirs;
  bool json = false;
  bool all = false;  // one line per cell, not only failed and running ones
};
int run_suite_status(const SuiteStatusOptions& options);

// `maps suite merge --out DIR SHARD...`: the finished cells of shard folders of one suite, copied into DIR (each
// through a temporary folder and a rename). Two shards with different results for one cell are an error.
struct SuiteMergeOptions {
  std::string out;
  std::vector<std::string> shards;
};
int run_suite_merge(const SuiteMergeOptions& options);

// `maps report DIR [--out DIR2]`: experiments/suites/report.py on Debian's python3 (results.csv, report.md,
// the paper's figures).
struct ReportOptions {
  std::string dir;
  std::string out;  // "" : DIR/report
};
int run_report(const ReportOptions& options);

}  // namespace maps::experiments
