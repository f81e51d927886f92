#pragma once
// Property tests of the file formats (issue 41, item 6): a valid file is damaged at random, from a fixed seed, and
// its reader must refuse the mutant with an exception that names the file, or accept it only where the format
// cannot tell (a value changed to another valid value), never crash or hang. ctest runs a bounded number per format;
// MAPS_PROPERTY_CASES raises it (scripts/reliability_table.sh), MAPS_PROPERTY_SEED draws other mutants and
// MAPS_PROPERTY_ONLY=i reads mutant i alone.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

namespace maps::testing {

// MAPS_PROPERTY_CASES, else `fallback`; a third of it (at least 20) under MAPS_TEST_QUICK=1, CI's sanitizer pass,
// where a case that writes and reads a file costs some 0.2 s (the fuzz targets mutate the same readers there).
inline int property_cases(int fallback) {
  const char* text = std::getenv("MAPS_PROPERTY_CASES");
  if (text && std::atoi(text) > 0) return std::atoi(text);
  const char* quick = std::getenv("MAPS_TEST_QUICK");
  return quick && std::string(quick) == "1" ? std::max(20, fallback / 3) : fallback;
}

inline std::uint64_t property_seed() {
  const char* text = std::getenv("MAPS_PROPERTY_SEED");
  return text ? std::strtoull(text, nullptr, 10) : 20261202ULL;
}

inline std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// One random damage of `bytes`: a truncation, flipped bits, overwritten, zeroed, deleted or repeated bytes. `how`
// says which, for a failure's message.
inline std::string byte_mutant(const std::string& bytes, std::mt19937_64& rng, std::string& how) {
  std::string out = bytes;
  auto below = [&rng](std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(rng() % n); };
  const std::size_t at = below(out.size());
  const std::size_t run = 1 + below(std::min<std::size_t>(32, out.size() - at));
  switch (rng() % 6) {
    case 0:
      out.resize(below(out.size()));
      how = "truncated to " + std::to_string(out.size()) + " bytes";
      break;
    case 1: {
      const int flips = 1 + static_cast<int>(below(8));
      for (int i = 0; i < flips; ++i) out[below(out.size())] ^= static_cast<char>(1u << below(8));
      how = std::to_string(flips) + " bits flipped";
      break;
    }
    case 2:
      for (std::size_t i = 0; i < run; ++i) out[at + i] = static_cast<char>(rng());
      how = std::to_string(run) + " bytes at " + std::to_string(at) + " overwritten";
      break;
    case 3:
      for (std::size_t i = 0; i < run; ++i) out[at + i] = '\0';
      how = std::to_string(run) + " bytes at " + std::to_string(at) + " zeroed";
      break;
    case 4:
      out.erase(at, run);
      how = std::to_string(run) + " bytes at " + std::to_string(at) + " deleted";
      break;
    default:
      out.insert(at, out.substr(at, run));
      how = std::to_string(run) + " bytes at " + std::to_string(at) + " repeated";
      break;
  }
  return out;
}

// One random structural edit of a JSON document: a value removed, replaced by a value of another kind or an edge
// value, an unknown key added, or nested 100 deep.
inline nlohmann::json json_mutant(const nlohmann::json& original, std::mt19937_64& rng, std::string& how) {
  using Json = nlohmann::json;
  std::vector<Json::json_pointer> nodes;
  std::vector<Json::json_pointer> stack{Json::json_pointer()};
  while (!stack.empty()) {  // every node's pointer, without recursion
    const Json::json_pointer at = stack.back();
    stack.pop_back();
    nodes.push_back(at);
    const Json& node = original.at(at);
    if (node.is_object())
      for (const auto& [key, value] : node.items()) stack.push_back(at / key);
    else if (node.is_array())
      for (std::size_t i = 0; i < node.size(); ++i) stack.push_back(at / i);
  }
  Json out = original;
  const Json::json_pointer at = nodes[rng() % nodes.size()];
  std::string deep(100, '[');
  deep += std::string(100, ']');
  const std::vector<Json> edges = {nullptr,
                                   true,
                                   -1,
                                   0,
                                   1,
                                   2.5,
                                   1e308,
                                   -1e308,
                                   "x",
                                   "",
                                   Json::object(),
                                   Json::array(),
                                   4294967297LL,
                                   18446744073709551615ULL,
                                   Json::parse(deep)};
  const int kind = static_cast<int>(rng() % 4);
  if (kind == 0 && !at.empty()) {
    Json& parent = out.at(at.parent_pointer());
    if (parent.is_object())
      parent.erase(at.back());
    else
      parent.erase(static_cast<std::size_t>(std::stoul(at.back())));
    how = "removed " + at.to_string();
  } else if (kind == 1 && out.at(at).is_object()) {
    out.at(at)["unknown_key"] = 1;
    how = "unknown key added at " + at.to_string();
  } else {
    const Json& edge = edges[rng() % edges.size()];
    out.at(at) = edge;
    how = at.to_string() + " = " + edge.dump().substr(0, 40);
  }
  return out;
}

struct PropertyCounts {
  int tried = 0;
  int refused = 0;
  int accepted = 0;
  double slowest_seconds = 0.0;
};

// Writes each of `cases` mutants of `original` (made by `mutate`) to `path` and calls `read(path)`: a refusal must be
// a std::exception naming `path`'s file (or `must_name`: a folder the file belongs to); an acceptance must pass
// `accepted_ok` (the checked fields equal the original's, or the invariants hold). A read slower than 60 s is a hang (a
// damaged header can keep libhdf5 busy for seconds before it fails). Prints one line of counts for
// docs/reliability.md.
inline PropertyCounts check_mutants(const std::string& format, const std::string& original, const std::string& path,
                                    int cases, const std::function<std::string(std::mt19937_64&, std::string&)>& mutate,
                                    const std::function<void(const std::string&)>& read,
                                    const std::function<bool(std::string&)>& accepted_ok,
                                    const std::string& must_name = "") {
  PropertyCounts counts;
  std::mt19937_64 rng(property_seed());
  // MAPS_PROPERTY_ONLY=i reads mutant i alone and keeps a copy of it, to look at a finding.
  const char* only_text = std::getenv("MAPS_PROPERTY_ONLY");
  const int only = only_text ? std::atoi(only_text) : -1;
  for (int i = 0; i < cases; ++i) {
    std::string how;
    const std::string bytes = mutate(rng, how);
    if (bytes == original || (only >= 0 && i != only)) continue;
    write_bytes(path, bytes);
    if (only >= 0) {  // kept where the test's folder (removed at its end) is not
      const std::string kept =
          (std::filesystem::temp_directory_path() /
           ("maps-property-mutant-" + std::to_string(i) + std::filesystem::path(path).extension().string()))
              .string();
      write_bytes(kept, bytes);
      std::cout << format << " mutant " << i << ": " << how << ", kept as " << kept << "\n";
    }
    ++counts.tried;
    const auto start = std::chrono::steady_clock::now();
    bool refused = false;
    try {
      read(path);
    } catch (const std::exception& e) {
      refused = true;
      ++counts.refused;
      const std::string what = e.what();
      const std::string name = must_name.empty() ? std::filesystem::path(path).filename().string() : must_name;
      EXPECT_NE(what.find(name), std::string::npos)
          << format << " mutant " << i << " (" << how << "): the error does not name " << name << ": " << what;
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    counts.slowest_seconds = std::max(counts.slowest_seconds, seconds);
    if (seconds > 1.0) std::cout << format << " mutant " << i << " (" << how << ") took " << seconds << " s\n";
    EXPECT_LT(seconds, 60.0) << format << " mutant " << i << " (" << how << "): a hang";
    if (refused) continue;
    ++counts.accepted;
    std::string why;
    EXPECT_TRUE(accepted_ok(why)) << format << " mutant " << i << " (" << how << ") was accepted: " << why;
  }
  std::cout << "property " << format << ": " << counts.tried << " mutants, " << counts.refused << " refused, "
            << counts.accepted << " accepted, 0 crashes, slowest read " << std::fixed << std::setprecision(4)
            << counts.slowest_seconds << std::defaultfloat << " s\n";
  return counts;
}

}  // namespace maps::testing
