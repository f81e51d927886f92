#include "experiments/suite/schema.h"

#include <functional>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "envs/expert_policy.h"
#include "experiments/cli/command.h"
#include "io/config_schema.h"
#include "maps/training/checkpoint_record.h"
#include "maps/training/run_config_fields.h"

namespace maps::experiments::cli {

namespace {

// The inputs whose keys `maps schema` prints, by the name the command line gives them.
struct SchemaKind {
  const char* name;
  std::function<std::vector<io::Field>()> fields;
};
const std::vector<SchemaKind>& schema_kinds() {
  static const std::vector<SchemaKind> kinds{{"run-config", [] { return core::run_config_schema(); }},
                                             {"suite-config", [] { return suite_config_schema(); }},
                                             {"policy-checkpoint", [] { return core::policy_record_schema(); }},
                                             {"training-checkpoint", [] { return core::training_state_schema(); }},
                                             {"expert", [] { return envs::expert_file_schema(); }}};
  return kinds;
}

struct SchemaOptions {
  std::string kind;
  bool markdown = false;
};

// Every key of an input kind with its type, default, range and meaning, as JSON or as the docs' markdown table
// (docs/configs.md's and docs/suite.md's tables of keys are this command's output).
int run_schema(const SchemaOptions& options) {
  std::vector<io::Field> fields;
  for (const SchemaKind& kind : schema_kinds())
    if (options.kind == kind.name) fields = kind.fields();
  if (fields.empty()) throw std::invalid_argument("maps schema: unknown kind '" + options.kind + "'");
  if (options.markdown) {
    std::cout << io::markdown_table(fields);
    return 0;
  }
  nlohmann::json out = nlohmann::json::array();
  for (const io::Field& f : fields)
    out.push_back({{"key", f.key},
                   {"type", f.type_name},
                   {"default", f.required ? nlohmann::json("required") : f.default_value},
                   {"range", io::range_text(f)},
                   {"expected", io::expectation(f)},
                   {"meaning", f.meaning}});
  std::cout << out.dump(2) << "\n";
  return 0;
}

}  // namespace

void add_schema(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<SchemaOptions>();
  CLI::App* command = tool.add_subcommand(
      "schema", "Every key of an input with its type, default, range and meaning (docs/configs.md's table)");
  std::vector<std::string> kinds;
  for (const SchemaKind& kind : schema_kinds()) kinds.push_back(kind.name);
  command
      ->add_option("kind", options->kind,
                   "The input: run-config, suite-config, policy-checkpoint (best.ckpt's record), "
                   "training-checkpoint (last.ckpt's) or expert (an expert file)")
      ->required()
      ->check(CLI::IsMember(kinds));
  command->add_flag("--markdown", options->markdown, "The docs' markdown table instead of JSON");
  commands.push_back({command, [options] { return run_schema(*options); }});
}

}  // namespace maps::experiments::cli
