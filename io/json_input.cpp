#include "io/json_input.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace maps::io {

nlohmann::json parse_json(std::string_view text, const std::string& what) {
  // The callback sees each value's depth as it starts, so a document is cut off at the first level too deep,
  // however long it is.
  const nlohmann::json::parser_callback_t limit_depth = [&what](int depth, nlohmann::json::parse_event_t event,
                                                                nlohmann::json&) {
    if ((event == nlohmann::json::parse_event_t::object_start || event == nlohmann::json::parse_event_t::array_start) &&
        depth >= kMaxJsonDepth)
      throw JsonTooDeep(what + " nests JSON deeper than " + std::to_string(kMaxJsonDepth) +
                        " levels (arrays and objects inside each other); no input of this tool nests so deep");
    return true;
  };
  try {
    return nlohmann::json::parse(text.begin(), text.end(), limit_depth);
  } catch (const nlohmann::json::exception& e) {
    std::string message = e.what();
    // "[json.exception.parse_error.101] parse error at line 1, ..." -> "parse error at line 1, ...": the id is
    // the library's, the position is what the user needs.
    if (const auto bracket = message.find("] ");
        message.rfind("[json.exception.", 0) == 0 && bracket != std::string::npos)
      message = message.substr(bracket + 2);
    throw std::runtime_error(what + " is not valid JSON: " + message);
  }
}

nlohmann::json read_json_file(const std::string& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status)) throw std::runtime_error("'" + path + "' does not exist");
  if (std::filesystem::is_directory(status))
    throw std::runtime_error("'" + path + "' is a folder, expected a JSON file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw std::runtime_error("cannot read '" + path + "'");
  return parse_json(text.str(), "'" + path + "'");
}

std::string string_or(const nlohmann::json& json, const std::string& key, const std::string& fallback) {
  if (!json.is_object()) return fallback;
  const auto found = json.find(key);
  return found != json.end() && found->is_string() ? found->get<std::string>() : fallback;
}

}  // namespace maps::io
