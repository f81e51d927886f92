#include "io/json_input.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace maps::io {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

std::string nested_arrays(int depth) { return std::string(depth, '[') + std::string(depth, ']'); }

std::string error_of(const std::string& text) {
  try {
    parse_json(text, "'cfg.json'");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(JsonInput, ParsesDocumentsUpToTheDepthLimit) {
  EXPECT_EQ(parse_json(nested_arrays(kMaxJsonDepth), "x").dump(), nested_arrays(kMaxJsonDepth));
  EXPECT_EQ(parse_json(R"({"a": {"b": [1, 2.5, "c", null, true]}})", "x")["a"]["b"][1], 2.5);
}

TEST(JsonInput, RefusesNestingPastTheLimitNamingTheInput) {
  EXPECT_THROW(parse_json(nested_arrays(kMaxJsonDepth + 1), "x"), JsonTooDeep);
  EXPECT_THAT(error_of(nested_arrays(kMaxJsonDepth + 1)),
              AllOf(HasSubstr("'cfg.json'"), HasSubstr("deeper than 64 levels")));
  // Objects count as arrays do, and a mixed nesting too.
  std::string objects;
  for (int i = 0; i <= kMaxJsonDepth; ++i) objects += "{\"k\":";
  objects += "1" + std::string(kMaxJsonDepth + 1, '}');
  EXPECT_THROW(parse_json(objects, "x"), JsonTooDeep);
}

TEST(JsonInput, AMillionLevelsAreRefusedWithoutExhaustingTheStack) {
  EXPECT_THROW(parse_json(nested_arrays(1000000), "x"), JsonTooDeep);
  EXPECT_THROW(parse_json(std::string(1000000, '['), "x"), JsonTooDeep);  // unclosed, as a truncated file
}

TEST(JsonInput, SyntaxErrorsNameTheInputAndThePosition) {
  EXPECT_THAT(error_of("{\"a\": 1,}"), AllOf(HasSubstr("'cfg.json' is not valid JSON"), HasSubstr("line 1, column 9")));
  EXPECT_THAT(error_of(""), HasSubstr("'cfg.json' is not valid JSON"));
  EXPECT_THAT(error_of("{} {}"), HasSubstr("'cfg.json' is not valid JSON"));
  EXPECT_THAT(error_of("\"\xff\""), HasSubstr("'cfg.json' is not valid JSON"));  // not UTF-8
  EXPECT_THAT(error_of("{\"a\": 1"), HasSubstr("'cfg.json' is not valid JSON"));
  // The library's own exception id is dropped: the message is for the user.
  EXPECT_THAT(error_of("nul"), ::testing::Not(HasSubstr("[json.exception")));
}

TEST(JsonInput, ReadJsonFileNamesAMissingFileAFolderAndBadContent) {
  const fs::path dir = fs::temp_directory_path() / ("maps_json_input_" + std::to_string(::getpid()));
  fs::create_directories(dir / "folder.json");
  std::ofstream(dir / "ok.json") << R"({"steps": 3})";
  std::ofstream(dir / "bad.json") << R"({"steps": )";
  EXPECT_EQ(read_json_file((dir / "ok.json").string())["steps"], 3);
  auto error = [](const fs::path& path) {
    try {
      read_json_file(path.string());
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_THAT(error(dir / "missing.json"),
              AllOf(HasSubstr((dir / "missing.json").string()), HasSubstr("does not exist")));
  EXPECT_THAT(error(dir / "folder.json"), AllOf(HasSubstr((dir / "folder.json").string()), HasSubstr("is a folder")));
  EXPECT_THAT(error(dir / "bad.json"), AllOf(HasSubstr((dir / "bad.json").string()), HasSubstr("not valid JSON")));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace maps::io
