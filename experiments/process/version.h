#pragma once

// What built this tool, recorded in every run folder (provenance.json) and printed by `maps --version`.
namespace maps::experiments {

const char* tool_version();     // the project's version (CMakeLists.txt)
const char* tool_git_commit();  // the commit built, "-dirty" when the tree had changes; "unknown ..." outside git
const char* tool_build();       // the build type, compiler, flags and the options that change the code

}  // namespace maps::experiments
