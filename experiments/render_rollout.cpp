// `maps render --run RUN`: frames of one episode of a trained policy, optionally with MAPS forced onto one module.

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <vector>

#include "envs/mujoco_env.h"
#include "envs/seed_ranges.h"
#include "envs/task_sets.h"
#include "experiments/render.h"
#include "experiments/render_view.h"
#include "experiments/run_folder.h"
#include "maps/policies/maps_policy.h"

namespace maps::experiments {

#ifdef MAPS_HAVE_RENDER
int run_render_policy(const RenderOptions& options) {
  if (options.frames < 1 || options.frames > 12)
    throw std::invalid_argument("--frames: expected 1 to 12 frames in the strip, got " +
                                std::to_string(options.frames));
  TrainedRun run = load_trained_run(options.run);
  const core::DemoDataset& data = *run.data;
  const auto& names = data.task_names();
  const auto found = std::find(names.begin(), names.end(), options.task);
  if (found == names.end()) {
    std::string list;
    for (const auto& name : names) list += (list.empty() ? "" : ", ") + name;
    throw std::invalid_argument("--task " + options.task + " is not a task of " + options.run + " (" + list + ")");
  }
  const std::int64_t task = found - names.begin();
  auto* maps_policy = dynamic_cast<core::MAPSPolicy*>(run.policy.get());
  if (options.module >= 0) {
    if (maps_policy == nullptr)
      throw std::invalid_argument("--module: " + options.run + " is a " + run.config.method +
                                  " run; only MAPS has modules");
    if (options.module >= maps_policy->num_modules())
      throw std::invalid_argument("--module " + std::to_string(options.module) + ": " + options.run +
                                  " has modules 0 to " + std::to_string(maps_policy->num_modules() - 1));
    maps_policy->force_module(options.module);
  }
  const ag::Dtype dtype = ag::Dtype::Float32;
  auto act = [&](const Eigen::VectorXd& observation) {
    ag::NoGradGuard no_grad;
    const ag::Tensor x = data.standardizer().apply(Eigen::MatrixXd(observation.transpose()), dtype);
    const ag::Tensor action = run.policy->act(x, {task});
    return Eigen::VectorXd(ag::to_eigen_double(action).row(0).transpose());
  };
  const std::uint64_t seed = options.seed_given ? options.seed : envs::kEvalSeedBegin;

  // The episode twice (policy and env are deterministic): its length first, then the frames spread over it.
  auto episode = [&](const std::vector<int>& at, envs::OffscreenRenderer* renderer, std::vector<envs::Image>* frames) {
    auto env = envs::make_env(options.task);
    auto& mujoco_env = dynamic_cast<envs::MujocoEnv&>(*env);
    Eigen::VectorXd obs = env->reset(seed);
    int steps = 0;
    double total = 0.0;
    bool success = false;
    for (;;) {
      if (renderer && std::find(at.begin(), at.end(), steps) != at.end()) {
        envs::CameraView view = default_view(mujoco_env);
        view.camera = options.camera;
        frames->push_back(renderer->render(mujoco_env.data(), view));
      }
      const envs::StepResult result = env->step(act(obs));
      ++steps;
      total += result.reward;
      success = success || result.success;
      obs = result.observation;
      if (result.done()) break;
    }
    if (renderer && std::find(at.begin(), at.end(), steps) != at.end()) {
      envs::CameraView view = default_view(mujoco_env);
      view.camera = options.camera;
      frames->push_back(renderer->render(mujoco_env.data(), view));
    }
    return std::make_tuple(steps, total, success);
  };
  const auto [length, episode_return, success] = episode({}, nullptr, nullptr);
  std::vector<int> at;
  for (int i = 0; i < options.frames; ++i)
    at.push_back(options.frames == 1 ? length : static_cast<int>(std::lround(1.0 * i * length / (options.frames - 1))));
  auto probe = envs::make_env(options.task);
  envs::OffscreenRenderer renderer(dynamic_cast<envs::MujocoEnv&>(*probe).model(), options.width, options.height);
  std::vector<envs::Image> frames;
  episode(at, &renderer, &frames);
  envs::Image strip;
  strip.width = options.width * static_cast<int>(frames.size());
  strip.height = options.height;
  strip.rgb.assign(static_cast<std::size_t>(strip.width) * strip.height * 3, 0);
  for (std::size_t f = 0; f < frames.size(); ++f)
    for (int row = 0; row < options.height; ++row)
      std::copy_n(frames[f].rgb.begin() + static_cast<std::ptrdiff_t>(row) * options.width * 3, options.width * 3,
                  strip.rgb.begin() + (static_cast<std::ptrdiff_t>(row) * strip.width + f * options.width) * 3);
  envs::write_png(options.out, strip);
  std::string steps_list;
  for (int s : at) steps_list += (steps_list.empty() ? "" : ", ") + std::to_string(s);
  std::printf("wrote %s: %s of %s (%s), seed %llu, %s; %d steps, return %.1f, %s; frames at steps %s\n",
              options.out.c_str(), options.task.c_str(), options.run.c_str(), run.config.method.c_str(),
              static_cast<unsigned long long>(seed),
              options.module >= 0 ? ("every score on module " + std::to_string(options.module)).c_str()
                                  : "the policy as trained",
              length, episode_return, success ? "succeeded" : "no success", steps_list.c_str());
  return 0;
}
#endif

}  // namespace maps::experiments
