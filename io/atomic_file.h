#pragma once

#include <functional>
#include <string>

// Files written whole or not at all: the one way every layer writes a file a reader may open meanwhile (checkpoints,
// run and suite JSON, demo files, experts, pictures), so that a kill, a full disk or a second writer never leaves
// half a file under the real name.
namespace maps::io {

// A temporary beside `path` for one writer: ".<name>.tmp-<host>-<pid>-<n>", so that two processes (even on two
// hosts sharing the folder) never write one temporary, and a suite folder's cleanup recognises what a killed writer
// left (the ".tmp-" in its name).
std::string temporary_path_for(const std::string& path);

// Calls `write` with a temporary path beside `path` to write the whole file there (a library that writes to a
// path, such as HDF5 or giflib), then fsyncs the temporary and renames it over `path`. On any failure, `write`'s
// exception included, the temporary is removed, `path` is left as it was and the error is rethrown (a failure of
// this function's own names `what` and `path`: "<what> <path>: ...").
void write_through_temporary(const std::string& path, const std::function<void(const std::string& temporary)>& write,
                             const std::string& what = "file");

// Writes `bytes` to `path` that way (the temporary created with O_EXCL and close-on-exec).
void write_file_atomically(const std::string& path, const std::string& bytes, const std::string& what = "file");

}  // namespace maps::io
