#pragma once

#include <string>

namespace maps::experiments {

struct SchemaOptions {
  std::string kind;  // run-config, suite-config, policy-checkpoint, training-checkpoint, expert
  bool markdown = false;
};

// `maps schema KIND`: every key of an input kind with its type, default, range and meaning, as JSON or as the
// docs' markdown table (docs/configs.md's and docs/suite.md's tables of keys are this command's output).
int run_schema(const SchemaOptions& options);

}  // namespace maps::experiments
