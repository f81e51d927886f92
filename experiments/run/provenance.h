#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "experiments/process/file_digest.h"  // sha256_of_file, which provenance records

// Where a run folder's results came from: each `maps train` invocation on it appends a record to
// DIR/provenance.json (a JSON array), so a folder trained, resumed and extended shows every process that wrote it.
namespace maps::experiments {

// {"tool_version", "git_commit", "started_utc" (ISO 8601), "command_line", "working_directory", "host", "cpu",
// "float32_gemm_kernel"}, "plugins" (each loaded plugin's path, SHA-256, version and registrations) when any is
// loaded, plus `extra`.
nlohmann::json provenance_record(const nlohmann::json& extra = nlohmann::json::object());

// Appends `record` to DIR/provenance.json (written atomically). A damaged file is an error naming it.
void append_provenance(const std::string& run_dir, const nlohmann::json& record);

}  // namespace maps::experiments
