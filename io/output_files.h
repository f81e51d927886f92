#pragma once

#include <string>
#include <vector>

// Checks made before a command starts its work, so that an output it cannot write is refused at once instead of
// after minutes of collecting or evaluating (issue 15: bad input never loses results).
namespace maps::io {

// `path` is a file the command will write (named on the command line by `option`): its folder is made if missing,
// and a probe file is created and removed there. Throws naming the option, the path and the reason.
void check_output_file(const std::string& option, const std::string& path);

// `dir` is a folder the command will write into: made if missing, and a probe file is created and removed there.
void check_output_folder(const std::string& option, const std::string& dir);

// The files named `names` that the command will write in the folder `dir` (made if missing): each must be absent or a
// regular file, and one the command appends to (`appended`) must open for appending. A folder or a socket where a
// result file belongs is refused naming it, before any work starts, instead of losing the result after it.
void check_output_files_in(const std::string& option, const std::string& dir, const std::vector<std::string>& names,
                           const std::vector<std::string>& appended = {});

}  // namespace maps::io
