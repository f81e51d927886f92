// `maps train`: one run of one method.

#include "experiments/train_run.h"

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <stdexcept>

#include "experiments/output_path.h"
#include "experiments/run_folder.h"
#include "maps/training/trainer.h"

namespace maps::experiments {

int run_train(const TrainRunOptions& options) {
  const core::RunConfig config = core::parse_run_config(read_json_file(options.config_path));
  const nlohmann::json resolved = core::to_json(config);
  check_output_folder("--out", options.out);
  const std::string config_path = (std::filesystem::path(options.out) / "config.json").string();
  // Compared after resolving both, so a folder written before a key existed (its default then implied) resumes.
  if (std::filesystem::exists(config_path) &&
      core::to_json(core::parse_run_config(read_json_file(config_path))) != resolved)
    throw std::runtime_error(options.out + " holds a run of another config (" + config_path +
                             "); use a new folder, or delete it to start over");
  write_json_file(config_path, resolved);

  const core::DemoDataset data = load_run_dataset(config);
  const core::PolicyShape shape{data.observation_size(), data.action_size(), data.num_tasks()};
  const auto policy = core::make_policy(config, shape);
  std::printf("maps train: %s on %s (%d tasks, %d demos per task, subsample %d), seed %llu, %lld steps -> %s\n",
              config.method.c_str(), config.data_file.c_str(), data.num_tasks(), config.data.demos_per_task,
              config.data.subsample, static_cast<unsigned long long>(config.seed),
              static_cast<long long>(config.train.steps), options.out.c_str());
  std::fflush(stdout);
  ag::set_num_threads(options.threads);
  const core::TrainSummary summary = core::train_policy(*policy, data, config.train, options.out, &std::cout);

  nlohmann::json seeds = nlohmann::json::object();
  for (int k = 0; k < data.num_tasks(); ++k) seeds[data.task_names()[k]] = data.training_demo_seeds()[k];
  write_json_file((std::filesystem::path(options.out) / "train.json").string(),
                  {{"steps", summary.steps_done},
                   {"best_step", summary.best_step},
                   {"best_validation_bc", summary.best_validation_loss},
                   {"seconds_this_process", summary.seconds},
                   {"resumed", summary.resumed},
                   {"parameters", policy->parameter_count()},
                   {"training_demo_seeds", seeds}});
  std::printf("done: best validation BC %.5g at step %lld; %s/best.ckpt\n", summary.best_validation_loss,
              static_cast<long long>(summary.best_step), options.out.c_str());
  return 0;
}

}  // namespace maps::experiments
