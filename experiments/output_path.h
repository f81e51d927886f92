#pragma once

#include <string>

// Checks made before a command starts its work, so that an output it cannot write is refused at once instead of
// after minutes of collecting or evaluating (issue 15: bad input never loses results).
namespace maps::experiments {

// `path` is a file the command will write (named on the command line by `option`): its folder is made if missing,
// and a probe file is created and removed there. Throws naming the option, the path and the reason.
void check_output_file(const std::string& option, const std::string& path);

// `dir` is a folder the command will write into: made if missing, and a probe file is created and removed there.
void check_output_folder(const std::string& option, const std::string& dir);

}  // namespace maps::experiments
