// `maps render --run RUN`: frames of one episode of a trained policy (a strip in a PNG, or every few steps as an
// animated GIF when --out ends in .gif), optionally with MAPS forced onto one module.

#include <algorithm>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <vector>

#include "envs/mujoco_env.h"
#include "envs/seed_ranges.h"
#include "envs/task_sets.h"
#include "experiments/render/render.h"
#include "experiments/render/render_view.h"
#include "experiments/run/run_folder.h"
#ifdef MAPS_HAVE_GIF
#include "envs/render/gif_file.h"
#endif
#include "maps/evaluation/step_actions.h"
#include "maps/policies/maps_policy.h"

namespace maps::experiments {

#ifdef MAPS_HAVE_RENDER
namespace {

bool ends_with_gif(const std::string& path) {
  return path.size() >= 4 &&
         (path.compare(path.size() - 4, 4, ".gif") == 0 || path.compare(path.size() - 4, 4, ".GIF") == 0);
}

// The steps an animation shows: every `every`-th step from 0, and the last.
std::vector<int> animation_steps(int length, int every) {
  std::vector<int> at;
  for (int step = 0; step < length; step += every) at.push_back(step);
  at.push_back(length);
  return at;
}

}  // namespace

int run_render_policy(const RenderOptions& options) {
  const bool gif = ends_with_gif(options.out);
#ifndef MAPS_HAVE_GIF
  if (gif) throw std::invalid_argument("--out " + options.out + ": this build has no GIF writer (install libgif-dev)");
#endif
  if (!gif && (options.frames < 1 || options.frames > 12))
    throw std::invalid_argument("--frames: expected 1 to 12 frames in the strip, got " +
                                std::to_string(options.frames));
  if (options.every < 0) throw std::invalid_argument("--every: expected >= 1 (0: about 150 frames in all)");
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
  // As the evaluator runs it: a policy predicting chunks through an executor, the previous state beside the current.
  const chunking::ActionChunking& chunks = run.policy->chunking();
  std::optional<chunking::ChunkExecutor> executor;
  Eigen::VectorXd previous;
  auto start_episode = [&](const Eigen::VectorXd& first) {
    previous = first;
    if (chunks.chunked()) executor.emplace(chunks, run.policy->step_action_size());
  };
  auto act = [&](const Eigen::VectorXd& observation) {
    ag::NoGradGuard no_grad;
    const ag::Tensor x = data.standardizer().apply(Eigen::MatrixXd(observation.transpose()), dtype);
    const ag::Tensor before = data.standardizer().apply(Eigen::MatrixXd(previous.transpose()), dtype);
    std::vector<chunking::ChunkExecutor*> executors;
    if (executor) executors.push_back(&*executor);
    previous = observation;
    return Eigen::VectorXd(
        core::step_actions(*run.policy, x, before, task, executors, "render: task '" + options.task + "'")
            .row(0)
            .transpose());
  };
  const std::uint64_t seed = options.seed_given ? options.seed : envs::kEvalSeedBegin;

  // The episode twice (policy and env are deterministic): its length first, then the frames spread over it.
  auto episode = [&](const std::vector<int>& at, envs::OffscreenRenderer* renderer, std::vector<envs::Image>* frames) {
    auto env = envs::make_env(options.task);
    auto& mujoco_env = dynamic_cast<envs::MujocoEnv&>(*env);
    Eigen::VectorXd obs = env->reset(seed);
    start_episode(obs);
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
  const int every = options.every > 0 ? options.every : std::max(1, (length + 149) / 150);
  if (gif) {
    at = animation_steps(length, every);
  } else {
    for (int i = 0; i < options.frames; ++i)
      at.push_back(options.frames == 1 ? length
                                       : static_cast<int>(std::lround(1.0 * i * length / (options.frames - 1))));
  }
  auto probe = envs::make_env(options.task);
  auto& probe_env = dynamic_cast<envs::MujocoEnv&>(*probe);
  envs::OffscreenRenderer renderer(probe_env.model(), options.width, options.height);
  std::vector<envs::Image> frames;
  episode(at, &renderer, &frames);
  const char* policy_label = run.config.method.c_str();
  const std::string forced =
      options.module >= 0 ? "every score on module " + std::to_string(options.module) : "the policy as trained";
#ifdef MAPS_HAVE_GIF
  if (gif) {
    // Real time: each frame stands for `every` env steps of dt seconds (at least 2 cs, what viewers honour).
    const int delay = std::max(2, static_cast<int>(std::lround(100.0 * every * probe_env.dt())));
    envs::write_gif(options.out, frames, delay);
    std::printf(
        "wrote %s: %s of %s (%s), seed %llu, %s; %d steps, return %.1f, %s; %zu frames (every %d steps, "
        "%d cs each)\n",
        options.out.c_str(), options.task.c_str(), options.run.c_str(), policy_label,
        static_cast<unsigned long long>(seed), forced.c_str(), length, episode_return,
        success ? "succeeded" : "no success", frames.size(), every, delay);
    return 0;
  }
#endif
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
              options.out.c_str(), options.task.c_str(), options.run.c_str(), policy_label,
              static_cast<unsigned long long>(seed), forced.c_str(), length, episode_return,
              success ? "succeeded" : "no success", steps_list.c_str());
  return 0;
}
#endif

}  // namespace maps::experiments
