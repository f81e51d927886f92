#pragma once

#include <string>

// The command line this process was started with, as provenance records and demo files keep it.
namespace maps::experiments {

// The command line as typed (arguments quoted where the shell would need it), set once by main().
void set_command_line(int argc, char** argv);
const std::string& command_line();

}  // namespace maps::experiments
