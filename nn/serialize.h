#pragma once

#include <string>

#include "nn/module.h"

// Checkpoint files: named tensors (dtype, shape, values) plus a free-form config string (the JSON that built
// the model), in one binary file.
//
// Format, version 1, little-endian:
//   "MAPSCKPT" (8 bytes) | u32 version | u32 reserved (0) | u64 payload size | payload | u64 FNV-1a-64(payload)
//   payload = u64 config size, config bytes, u64 tensor count, then per tensor:
//             u32 name size, name bytes, u8 dtype (1 float32, 2 float64), u8 rank, rank x i64 dims, raw values
// Writing goes to a temporary file in the same folder, fsync'ed, then renamed over `path`, so a reader never
// sees a half-written checkpoint. Reading checks the magic, the version, the exact size (truncation or trailing
// bytes), the checksum and every field; each error names the file and what is wrong.
namespace maps::nn {

struct Checkpoint {
  std::string config;
  NamedTensors tensors;
};

// Writes `bytes` to `path` through a temporary in the same folder (named for this host, process and call; O_EXCL,
// close-on-exec), fsync-ed and renamed over `path`: a reader never sees half a file, two processes (even on two
// hosts sharing the folder) never write one temporary. Throws std::runtime_error "<what> <path>: ..." (what:
// "checkpoint" for checkpoints, "file" otherwise); the temporary is removed on any error.
void write_file_atomically(const std::string& path, const std::string& bytes, const std::string& what = "file");

void save_tensors(const std::string& path, const NamedTensors& tensors, const std::string& config = "");
Checkpoint load_tensors(const std::string& path);

// module.state_dict() (parameters and buffers) and `config` to `path`.
void save(const Module& module, const std::string& path, const std::string& config = "");
// Loads `path` into `module` (every name, shape and dtype must match, see Module::load_state_dict) and returns
// the stored config. The module is unchanged when anything is wrong.
std::string load(Module& module, const std::string& path);

}  // namespace maps::nn
