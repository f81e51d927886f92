#pragma once
// JSON from outside the program (configs, run folders, checkpoint records, expert files, --set values).

#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <string_view>

namespace maps::io {

// Deeper than any file of this project (a run config nests 3 levels, a suite config 5); a deeper document is
// refused while it is parsed, before code that walks JSON recursively (dump, comparison) could exhaust the stack.
inline constexpr int kMaxJsonDepth = 64;

// A document nested deeper than kMaxJsonDepth (apart from other errors: a --set value that is not JSON is a string,
// one nested too deep is refused).
class JsonTooDeep : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses `text` as one JSON document. Throws std::runtime_error naming `what` (a file's path, "--set KEY") on a
// syntax error, JsonTooDeep on nesting deeper than kMaxJsonDepth.
nlohmann::json parse_json(std::string_view text, const std::string& what);

// Reads and parses the file at `path` as parse_json does; a missing or unreadable file, or a folder, is an error
// naming it.
nlohmann::json read_json_file(const std::string& path);

// `json[key]` when `json` is an object holding a string there, else `fallback`. nlohmann's value() throws a bare
// type_error ("type must be string") for a key of another type, which names neither the file nor the key.
std::string string_or(const nlohmann::json& json, const std::string& key, const std::string& fallback);

}  // namespace maps::io
