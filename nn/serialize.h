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

// save_tensors writes through io::write_file_atomically; its errors read "checkpoint <path>: ...".
void save_tensors(const std::string& path, const NamedTensors& tensors, const std::string& config = "");
Checkpoint load_tensors(const std::string& path);

// module.state_dict() (parameters and buffers) and `config` to `path`.
void save(const Module& module, const std::string& path, const std::string& config = "");
// Loads `path` into `module` (every name, shape and dtype must match, see Module::load_state_dict) and returns
// the stored config. The module is unchanged when anything is wrong.
std::string load(Module& module, const std::string& path);

// For a checkpoint holding several modules' tensors side by side: appends `tensors` to `out` renamed prefix + name;
// and the tensors whose name starts with `prefix`, the prefix removed.
void append_with_prefix(NamedTensors& out, const NamedTensors& tensors, const std::string& prefix);
NamedTensors strip_prefix(const NamedTensors& tensors, const std::string& prefix);

}  // namespace maps::nn
