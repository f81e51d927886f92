#pragma once
// Edge values of a schema key's type (issue 41), for the tests that walk every key of an input kind's schema:
// the bounds, one past them, 0, -1, 2^32 + 1, the type's own limits + 1, NaN, infinities, 1e308, a string, null, an
// object, each with whether the key's own range accepts it (computed here from the bounds, not by check_value).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/config_schema.h"

namespace maps::io {

using Json = nlohmann::json;

struct Trial {
  Json value;
  bool in_range;  // what the field alone says of it
};

// Whether a JSON integer fits the field's bounds, computed here from the bounds (not by check_value).
inline bool integer_in_range(const io::Field& f, long double x) {
  return (f.min_exclusive ? x > f.min : x >= f.min) && x <= f.max;
}

// Edge values of a scalar of the field: the bounds, one past them, zero, -1, other types, null, an object.
inline std::vector<Trial> scalar_trials(const io::Field& f, ValueKind kind) {
  std::vector<Trial> trials = {{Json(nullptr), f.nullable}, {Json::object(), false}, {Json::array({1}), false}};
  const double nan = std::nan("");
  const double inf = std::numeric_limits<double>::infinity();
  switch (kind) {
    case ValueKind::kBoolean:
      trials.insert(trials.end(), {{true, true}, {false, true}, {0, false}, {1, false}, {"true", false}});
      break;
    case ValueKind::kInteger: {
      // nlohmann keeps integers exact up to 2^64 - 1; a bound past that is the type's.
      auto json_integer = [](long double x) -> Json {
        if (x < 0) return Json(static_cast<std::int64_t>(x));
        return Json(static_cast<std::uint64_t>(x));
      };
      for (long double x : {0.0L, -1.0L, 1.0L, 4294967297.0L /* 2^32 + 1: wrapped to 1 in an int before */,
                            2147483648.0L /* int's max + 1 */, 9223372036854775808.0L /* int64's max + 1 */,
                            -9223372036854775807.0L - 1.0L}) {
        trials.push_back({json_integer(x), integer_in_range(f, x)});
      }
      for (long double bound : {f.min, f.max})
        if (std::isfinite(bound)) trials.push_back({json_integer(bound), integer_in_range(f, bound)});
      if (std::isfinite(f.min) && f.min > -9223372036854775807.0L) trials.push_back({json_integer(f.min - 1), false});
      if (std::isfinite(f.max) && f.max < io::kMaxUint64) trials.push_back({json_integer(f.max + 1), false});
      if (f.max == io::kMaxUint64) trials.push_back({Json(18446744073709551616.0), false});  // 2^64: a float
      trials.insert(
          trials.end(),
          {{1.5, false}, {2.0, false}, {1e308, false}, {nan, false}, {inf, false}, {"1", false}, {true, false}});
      break;
    }
    case ValueKind::kNumber: {
      auto in_range = [&f](double x) {
        return std::isfinite(x) && (f.min_exclusive ? x > f.min : x >= f.min) && x <= f.max;
      };
      for (double x : {0.0, -1.0, 1.0, 0.5, 1e308, -1e308, 1e-300}) trials.push_back({x, in_range(x)});
      for (long double bound : {f.min, f.max})
        if (std::isfinite(bound)) {
          const double b = static_cast<double>(bound);
          trials.push_back({b, in_range(b)});
          trials.push_back({std::nextafter(b, b == static_cast<double>(f.min) ? -inf : inf), false});
        }
      trials.insert(trials.end(), {{nan, false}, {inf, false}, {-inf, false}, {"1", false}, {true, false}});
      trials.push_back({Json(3), in_range(3.0)});  // a JSON integer is a number
      break;
    }
    case ValueKind::kString:
      trials.insert(trials.end(), {{1, false}, {true, false}});
      // A list's non_empty is the list's, not its strings'.
      trials.push_back({"", (f.kind == ValueKind::kStringList || !f.non_empty) && f.choices.empty()});
      trials.push_back({"no such choice", f.choices.empty()});
      for (const std::string& choice : f.choices) trials.push_back({choice, true});
      break;
    default:
      ADD_FAILURE() << "not a scalar kind";
  }
  return trials;
}

inline std::vector<Trial> trials_of(const io::Field& f) {
  switch (f.kind) {
    case ValueKind::kIntegerList:
    case ValueKind::kNumberList:
    case ValueKind::kStringList: {
      const ValueKind element = f.kind == ValueKind::kIntegerList  ? ValueKind::kInteger
                                : f.kind == ValueKind::kNumberList ? ValueKind::kNumber
                                                                   : ValueKind::kString;
      std::vector<Trial> trials = {
          {Json::array(), !f.non_empty}, {Json(nullptr), false}, {Json::object(), false}, {"a", false}, {1, false}};
      for (const Trial& t : scalar_trials(f, element)) trials.push_back({Json::array({t.value}), t.in_range});
      if (f.unique)
        for (const Trial& t : scalar_trials(f, element))
          if (t.in_range) trials.push_back({Json::array({t.value, t.value}), false});
      return trials;
    }
    case ValueKind::kIntegerMap:
    case ValueKind::kNumberMap: {
      const ValueKind element = f.kind == ValueKind::kIntegerMap ? ValueKind::kInteger : ValueKind::kNumber;
      std::vector<Trial> trials = {{Json::object(), true}, {Json(nullptr), false}, {Json::array(), false}, {1, false}};
      for (const Trial& t : scalar_trials(f, element)) trials.push_back({Json{{"some_name", t.value}}, t.in_range});
      return trials;
    }
    case ValueKind::kObject:
      return {{Json::object(), true}, {Json(nullptr), false}, {Json::array(), false}, {1, false}, {"a", false}};
    default:
      return scalar_trials(f, f.kind);
  }
}

struct WalkCounts {
  int tried = 0;
  int refused = 0;
};

// Tries every trial value of every field: `parse(field, value)` reads an input holding the value at the field's key
// and returns normally when it accepts it; `refused(field, trial, error)` checks a refusal (an `Error`, the only
// exception allowed), `accepted(field, trial)` an acceptance, which a value outside the key's range must
// never get.
// `through_text`: the parser reads the value from JSON text, where NaN and the infinities are written as null.
template <typename Error = std::invalid_argument, typename Parse, typename Refused, typename Accepted>
WalkCounts walk_schema(const std::vector<Field>& fields, Parse parse, Refused refused, Accepted accepted,
                       bool through_text = false) {
  WalkCounts counts;
  for (const Field& field : fields) {
    for (Trial trial : trials_of(field)) {
      if (through_text && trial.value.is_number_float() && !std::isfinite(trial.value.get<double>()))
        trial = {Json(nullptr), field.nullable};
      ++counts.tried;
      const std::string what = field.key + " = " + trial.value.dump();
      try {
        parse(field, trial.value);
      } catch (const Error& e) {
        ++counts.refused;
        refused(field, trial, std::string(e.what()));
        continue;
      } catch (const std::exception& e) {
        ADD_FAILURE() << what << ": not std::invalid_argument: " << e.what();
        continue;
      }
      EXPECT_TRUE(trial.in_range) << what << " was accepted";
      accepted(field, trial);
    }
  }
  std::cout << "tried " << counts.tried << " values of " << fields.size() << " keys, " << counts.refused
            << " refused\n";
  return counts;
}

}  // namespace maps::io
