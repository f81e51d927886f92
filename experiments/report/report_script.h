#pragma once

#include <string>

namespace maps::experiments {

// `maps report DIR [--out DIR2]`: experiments/report/report.py on Debian's python3 (results.csv, report.md,
// the paper's figures).
struct ReportOptions {
  std::string dir;
  std::string out;  // "" : DIR/report
  // The study a quick-scale suite is shown beside (report.py --study; "": the checkout's results/study), or none.
  std::string study;
  bool no_study = false;
};
int run_report(const ReportOptions& options);

}  // namespace maps::experiments
