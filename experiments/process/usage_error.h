#pragma once

#include <stdexcept>

namespace maps::experiments {

// A command line that cannot work (a missing option, options that exclude each other): main() prints it and exits
// with 2, as for the errors CLI11 finds itself (docs/cli.md, exit codes).
struct UsageError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

}  // namespace maps::experiments
