#pragma once

#include <string>

namespace maps::experiments {

// The SHA-256 of a file's bytes as 64 lowercase hex digits (the value `sha256sum FILE` prints): provenance's
// fingerprint of a demo file or a plugin. Throws naming the file when it cannot be read.
std::string sha256_of_file(const std::string& path);

}  // namespace maps::experiments
