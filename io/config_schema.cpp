#include "io/config_schema.h"

#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>

namespace maps::io {
namespace {

bool is_list(ValueKind kind) {
  return kind == ValueKind::kIntegerList || kind == ValueKind::kNumberList || kind == ValueKind::kStringList;
}
bool is_map(ValueKind kind) { return kind == ValueKind::kIntegerMap || kind == ValueKind::kNumberMap; }

// The kind of an element of a list or a value of a map.
ValueKind element_kind(ValueKind kind) {
  switch (kind) {
    case ValueKind::kIntegerList:
    case ValueKind::kIntegerMap:
      return ValueKind::kInteger;
    case ValueKind::kNumberList:
    case ValueKind::kNumberMap:
      return ValueKind::kNumber;
    case ValueKind::kStringList:
      return ValueKind::kString;
    default:
      return kind;
  }
}

// A bound as text: integers exactly, other numbers as the shortest %g that reads back.
std::string number_text(long double x) {
  if (std::isinf(x)) return x > 0 ? "inf" : "-inf";
  if (x == std::floor(x) && std::fabs(x) <= kMaxUint64) {
    if (x < 0) return std::to_string(static_cast<long long>(x));
    return std::to_string(static_cast<unsigned long long>(x));
  }
  std::ostringstream out;
  out.precision(17);
  out << static_cast<double>(x);
  std::string shortest = out.str();
  for (int precision = 1; precision < 17; ++precision) {
    std::ostringstream trial;
    trial.precision(precision);
    trial << static_cast<double>(x);
    if (std::stod(trial.str()) == static_cast<double>(x)) return trial.str();
  }
  return shortest;
}

bool bounded_below(const Field& f) { return !std::isinf(f.min); }

// Whether a number lies within the field's bounds (a NaN does not).
bool within(const Field& f, long double x) { return (f.min_exclusive ? x > f.min : x >= f.min) && x <= f.max; }
bool bounded_above(const Field& f) { return !std::isinf(f.max); }

// The range of one scalar, in words for errors ("in [1, 100]", ">= 0", "> 0").
std::string bounds_words(const Field& f) {
  const std::string low = number_text(f.min), high = number_text(f.max);
  if (bounded_below(f) && bounded_above(f))
    return std::string(" in ") + (f.min_exclusive ? "(" : "[") + low + ", " + high + "]";
  if (bounded_below(f)) return (f.min_exclusive ? " > " : " >= ") + low;
  if (bounded_above(f)) return " <= " + high;
  return "";
}

std::string scalar_expectation(const Field& f, ValueKind kind) {
  switch (kind) {
    case ValueKind::kBoolean:
      return "true or false";
    case ValueKind::kInteger:
      return "an integer" + bounds_words(f);
    case ValueKind::kNumber:
      return "a finite number" + bounds_words(f);
    case ValueKind::kString: {
      if (f.choices.empty()) return f.non_empty && !is_list(f.kind) ? "a non-empty string" : "a string";
      std::string text;
      for (std::size_t i = 0; i < f.choices.size(); ++i)
        text += std::string(i == 0 ? "" : i + 1 == f.choices.size() ? " or " : ", ") + "\"" + f.choices[i] + "\"";
      return text;
    }
    default:
      return "";
  }
}

// Whether a scalar has the kind and lies in the field's range.
bool scalar_fits(const Field& f, ValueKind kind, const nlohmann::json& value) {
  switch (kind) {
    case ValueKind::kBoolean:
      return value.is_boolean();
    case ValueKind::kInteger: {
      // nlohmann reads 2.5 and 1e3 as floats and integers beyond uint64 as floats: an integer must be written
      // as one, and within the type it is stored in.
      long double x;
      if (value.is_number_unsigned())
        x = static_cast<long double>(value.get<std::uint64_t>());
      else if (value.is_number_integer())
        x = static_cast<long double>(value.get<std::int64_t>());
      else
        return false;
      return within(f, x);
    }
    case ValueKind::kNumber: {
      if (!value.is_number()) return false;
      const long double x = value.is_number_unsigned()  ? static_cast<long double>(value.get<std::uint64_t>())
                            : value.is_number_integer() ? static_cast<long double>(value.get<std::int64_t>())
                                                        : static_cast<long double>(value.get<double>());
      return std::isfinite(x) && within(f, x);
    }
    case ValueKind::kString: {
      if (!value.is_string()) return false;
      const std::string& text = value.get_ref<const std::string&>();
      if (f.non_empty && !is_list(f.kind) && text.empty()) return false;  // a list's non_empty is the list's
      if (f.choices.empty()) return true;
      for (const std::string& choice : f.choices)
        if (choice == text) return true;
      return false;
    }
    default:
      return false;
  }
}

// A value for an error: short, whatever it is (a huge array is cut, a deep one was refused by the parser).
std::string shown(const nlohmann::json& value) {
  std::string text = value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (text.size() > 80) text = text.substr(0, 77) + "...";
  return text;
}

}  // namespace

nlohmann::json::json_pointer key_pointer(std::string dotted_key) {
  for (char& c : dotted_key)
    if (c == '.') c = '/';
  dotted_key.insert(dotted_key.begin(), '/');
  return nlohmann::json::json_pointer(dotted_key);
}

const nlohmann::json* find_key(const nlohmann::json& document, const std::string& dotted_key) {
  const nlohmann::json* node = &document;
  for (std::size_t start = 0;;) {
    const std::size_t dot = dotted_key.find('.', start);
    const std::string part = dotted_key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!node->is_object() || !node->contains(part)) return nullptr;
    node = &node->at(part);
    if (dot == std::string::npos) return node;
    start = dot + 1;
  }
}

std::string expectation(const Field& f) {
  if (f.nullable) {
    Field plain = f;
    plain.nullable = false;
    return expectation(plain) + " or null";
  }
  if (f.kind == ValueKind::kObject) return "an object";
  if (is_list(f.kind)) {
    std::string element = scalar_expectation(f, element_kind(f.kind));
    return std::string(f.non_empty ? "a non-empty list" : "a list") + " of " +
           (!f.choices.empty()             ? "strings, each " + element
            : element.rfind("an ", 0) == 0 ? element.substr(3) + "s"
                                           : element.substr(2) + "s");
  }
  if (is_map(f.kind)) {
    const std::string value = scalar_expectation(f, element_kind(f.kind));
    return "an object of name: " + value.substr(value.find(' ') + 1);
  }
  return scalar_expectation(f, f.kind);
}

void check_value(const Field& f, const nlohmann::json& value, const std::string& prefix) {
  if (f.nullable && value.is_null()) return;
  auto fail = [&](const std::string& where, const std::string& expected, const nlohmann::json& got) {
    throw std::invalid_argument(prefix + where + ": expected " + expected + ", got " + shown(got));
  };
  if (is_list(f.kind)) {
    if (!value.is_array()) fail(f.key, expectation(f), value);
    if (f.non_empty && value.empty()) fail(f.key, expectation(f), value);
    for (std::size_t i = 0; i < value.size(); ++i) {
      if (!scalar_fits(f, element_kind(f.kind), value[i]))
        fail(f.key + "[" + std::to_string(i) + "]", scalar_expectation(f, element_kind(f.kind)), value[i]);
      if (f.unique)
        for (std::size_t j = 0; j < i; ++j)
          if (value[j] == value[i])
            throw std::invalid_argument(prefix + f.key + ": " + shown(value[i]) + " is listed twice");
    }
    return;
  }
  if (is_map(f.kind)) {
    if (!value.is_object()) fail(f.key, expectation(f), value);
    for (const auto& [name, inner] : value.items())
      if (!scalar_fits(f, element_kind(f.kind), inner))
        fail(f.key + "." + name, scalar_expectation(f, element_kind(f.kind)), inner);
    return;
  }
  if (f.kind == ValueKind::kObject) {
    if (!value.is_object()) fail(f.key, expectation(f), value);
    return;
  }
  if (!scalar_fits(f, f.kind, value)) fail(f.key, expectation(f), value);
}

std::string range_text(const Field& f) {
  const ValueKind kind = element_kind(f.kind);
  std::string text;
  if (kind == ValueKind::kString && !f.choices.empty()) {
    for (std::size_t i = 0; i < f.choices.size(); ++i)
      text += std::string(i == 0 ? "" : i + 1 == f.choices.size() ? " or " : ", ") + "`" + f.choices[i] + "`";
  } else if (kind == ValueKind::kInteger || kind == ValueKind::kNumber) {
    text = bounds_words(f);
    if (!text.empty() && text[0] == ' ') text = text.substr(1);
    if (text.rfind("in ", 0) == 0) text = text.substr(3);
  }
  if (f.unique) text = "no repeats" + std::string(text.empty() ? "" : "; ") + text;
  if (f.non_empty) text = (is_list(f.kind) ? "non-empty" : "not empty") + std::string(text.empty() ? "" : "; ") + text;
  return text;
}

Field integer_option(std::string key, std::int64_t default_value, std::int64_t min, std::int64_t max,
                     std::string meaning) {
  Field f;
  f.key = std::move(key);
  f.kind = ValueKind::kInteger;
  f.type_name = "int";
  f.min = static_cast<long double>(min);
  f.max = static_cast<long double>(max);
  f.default_value = default_value;
  f.meaning = std::move(meaning);
  return f;
}

Field number_option(std::string key, double default_value, double min, double max, std::string meaning) {
  Field f;
  f.key = std::move(key);
  f.kind = ValueKind::kNumber;
  f.type_name = "float";
  f.min = min;
  f.max = max;
  f.default_value = default_value;
  f.meaning = std::move(meaning);
  return f;
}

Field boolean_option(std::string key, bool default_value, std::string meaning) {
  Field f;
  f.key = std::move(key);
  f.kind = ValueKind::kBoolean;
  f.type_name = "bool";
  f.default_value = default_value;
  f.meaning = std::move(meaning);
  return f;
}

Field choice_option(std::string key, std::string default_value, std::vector<std::string> choices, std::string meaning) {
  Field f;
  f.key = std::move(key);
  f.kind = ValueKind::kString;
  f.type_name = "string";
  f.choices = std::move(choices);
  f.default_value = std::move(default_value);
  f.meaning = std::move(meaning);
  return f;
}

std::string markdown_table(const std::vector<Field>& fields) {
  std::string out = "| key | type | default | range | meaning |\n|---|---|---|---|---|\n";
  for (const Field& f : fields) {
    std::string dflt = f.required ? "required" : "none";
    if (!f.required && !f.default_value.is_null()) {
      dflt = "`";
      dflt += f.default_value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      dflt += "`";
    }
    // JSON's separators as a person writes them: {"a": 1, "b": 2}, [1, 2].
    std::string spaced;
    bool in_string = false;
    for (std::size_t i = 0; i < dflt.size(); ++i) {
      const char c = dflt[i];
      if (c == '"' && (i == 0 || dflt[i - 1] != '\\')) in_string = !in_string;
      spaced += c;
      if (!in_string && (c == ',' || c == ':')) spaced += ' ';
    }
    out += "| `" + f.key + "` | " + f.type_name + " | " + spaced + " | " + range_text(f) + " | " + f.meaning + " |\n";
  }
  return out;
}

}  // namespace maps::io
