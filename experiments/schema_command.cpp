#include "experiments/schema_command.h"

#include <iostream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "envs/expert_policy.h"
#include "experiments/suite_schema.h"
#include "io/config_schema.h"
#include "maps/training/checkpoint_record.h"
#include "maps/training/run_config_fields.h"

namespace maps::experiments {

int run_schema(const SchemaOptions& options) {
  std::vector<io::Field> fields;
  if (options.kind == "run-config") {
    fields = core::run_config_schema();
  } else if (options.kind == "suite-config") {
    fields = suite_config_schema();
  } else if (options.kind == "policy-checkpoint") {
    fields = core::policy_record_schema();
  } else if (options.kind == "training-checkpoint") {
    fields = core::training_state_schema();
  } else if (options.kind == "expert") {
    fields = envs::expert_file_schema();
  } else {
    throw std::invalid_argument("maps schema: unknown kind '" + options.kind + "'");
  }
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

}  // namespace maps::experiments
