#pragma once

// A header of the user's own project that happens to share a name with one of the library's (nn/mlp.h): the
// library's headers are under the maps/ prefix, so both can be included side by side.
namespace user {
inline constexpr const char* kWhoseMlp = "the user's own nn/mlp.h";
}
