#pragma once

#include <string>

namespace maps::experiments {

// `maps report DIR [--out DIR2]`: experiments/report/report.py on Debian's python3 (results.csv, report.md,
// the paper's figures).
struct ReportOptions {
  std::string dir;
  std::string out;  // "" : DIR/report
};
int run_report(const ReportOptions& options);

}  // namespace maps::experiments
