#pragma once
// A typed key of a JSON input (a run config, a suite config, a checkpoint's record): its type, its range, its
// default and what it means. One table of these per input kind checks every value at load and writes the docs'
// table of keys, so a key cannot be checked one way and documented another.

#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace maps::io {

enum class ValueKind {
  kBoolean,
  kInteger,
  kNumber,
  kString,
  kIntegerList,
  kNumberList,
  kStringList,
  kIntegerMap,  // an object of name: integer
  kNumberMap,   // an object of name: number
  kObject,      // any object (a partial run config: its keys are the run config's to check)
};

struct Field {
  std::string key;  // dotted: "train.steps"
  ValueKind kind = ValueKind::kString;
  // As the docs write it: "int64", "uint64", "int", "float", "string list", "object name: float".
  std::string type_name;
  // Inclusive bounds of a number, an integer, or each element or value of a list or map. Integers are compared
  // exactly (long double holds every 64-bit integer). The bounds of an integer include those of the type it is
  // stored in, so no value wraps.
  long double min = -std::numeric_limits<long double>::infinity();
  long double max = std::numeric_limits<long double>::infinity();
  bool min_exclusive = false;        // (min, max]: a learning rate must be > 0
  std::vector<std::string> choices;  // a string must be one of these (empty: any string)
  bool non_empty = false;            // a string or list must not be empty
  bool unique = false;               // a list must not name an element twice
  bool required = false;             // no default: the key must be given
  bool nullable = false;             // null is a value too (a loss not computed yet)
  nlohmann::json default_value;      // as the docs show it; null: "required", or "none" (the key is optional)
  std::string meaning;               // the docs' text: what it does, and what a special value (0: all) means
};

// A field's dotted key ("train.steps") as a JSON pointer ("/train/steps"): where its value sits in a document, to
// write it there (json[pointer] makes the objects on the way).
nlohmann::json::json_pointer key_pointer(std::string dotted_key);

// The value at a dotted key, or nullptr when a part of the way is missing or is not an object.
const nlohmann::json* find_key(const nlohmann::json& document, const std::string& dotted_key);

// Throws std::invalid_argument "<prefix><key>: expected <expectation>, got <value>" unless `value` is of the
// field's kind and within its range. A NaN or an infinity is never a number here.
void check_value(const Field& field, const nlohmann::json& value, const std::string& prefix = "config ");

// What a value must be, as an error says it: "an integer in [1, 9223372036854775807]", "\"a\", \"b\" or \"c\"".
std::string expectation(const Field& field);

// The range column of the docs: ">= 1", "[0, 1]", "> 0", "`mean` or `sampled`", "" when any value of the type is
// accepted.
std::string range_text(const Field& field);

// The docs' table of keys (| key | type | default | range | meaning |), a row per field, in order.
std::string markdown_table(const std::vector<Field>& fields);

// A method's option ("experts": 4 in the section "moore"), with the type name the docs give it.
Field integer_option(std::string key, std::int64_t default_value, std::int64_t min, std::int64_t max,
                     std::string meaning);
Field number_option(std::string key, double default_value, double min, double max, std::string meaning);
Field boolean_option(std::string key, bool default_value, std::string meaning);
Field choice_option(std::string key, std::string default_value, std::vector<std::string> choices, std::string meaning);

static_assert(std::numeric_limits<long double>::digits >= 64, "bounds compare 64-bit integers exactly as long double");

// Limits shared by several inputs.
inline constexpr long double kMaxInt64 = static_cast<long double>(std::numeric_limits<std::int64_t>::max());
inline constexpr long double kMaxUint64 = static_cast<long double>(std::numeric_limits<std::uint64_t>::max());

}  // namespace maps::io
