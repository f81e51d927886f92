// `maps render`: a picture of a task's scene, so a person can check that it is built right.

#include "experiments/render/render.h"

#include <cstdio>
#include <stdexcept>

#include "envs/mujoco_env.h"
#include "envs/task_expert.h"
#include "envs/task_sets.h"
#include "experiments/render/render_view.h"
#include "io/output_files.h"

namespace maps::experiments {

#ifdef MAPS_HAVE_RENDER
envs::CameraView default_view(const envs::MujocoEnv& env) {
  envs::CameraView view;
  if (env.spec().task.rfind("mt10/", 0) == 0) {
    // The table from the robot's left front, high enough to see into drawers and onto buttons.
    view.lookat[0] = 0.0;
    view.lookat[1] = 0.7;
    view.lookat[2] = 0.1;
    view.distance = 0.95;
    view.azimuth = 135.0;
    view.elevation = -35.0;
  } else {
    // HalfCheetah from the side, following the torso.
    const mjData* d = env.data();
    const int torso = mj_name2id(env.model(), mjOBJ_BODY, "torso");
    for (int i = 0; i < 3; ++i) view.lookat[i] = torso >= 0 ? d->xpos[3 * torso + i] : 0.0;
    view.distance = 4.0;
    view.azimuth = 90.0;
    view.elevation = -15.0;
  }
  return view;
}
#endif

int run_render(const RenderOptions& options) {
#ifndef MAPS_HAVE_RENDER
  (void)options;
  throw std::runtime_error(
      "this build has no renderer: install libosmesa6-dev and libpng-dev (scripts/setup.sh does), then reconfigure "
      "with cmake (MAPS_BUILD_RENDER=ON)");
#else
  io::check_output_file("--out", options.out);
  if (!options.run.empty()) return run_render_policy(options);
  auto env = envs::make_env(options.task);
  auto* mujoco_env = dynamic_cast<envs::MujocoEnv*>(env.get());
  if (!mujoco_env) throw std::runtime_error("task '" + options.task + "' is not a MuJoCo env; nothing to draw");
  Eigen::VectorXd obs = env->reset(options.seed);
  int stepped = 0;
  if (options.steps > 0) {
    const envs::TaskExpert expert = envs::load_task_expert(options.task);
    for (; stepped < options.steps; ++stepped) {
      const envs::StepResult result = env->step(expert.mean_action(obs));
      obs = result.observation;
      if (result.done()) {
        ++stepped;
        break;
      }
    }
  }
  envs::CameraView view = default_view(*mujoco_env);
  view.camera = options.camera;
  envs::OffscreenRenderer renderer(mujoco_env->model(), options.width, options.height);
  envs::write_png(options.out, renderer.render(mujoco_env->data(), view));
  std::printf("wrote %s: %s, seed %llu, after %d expert steps, %d x %d\n", options.out.c_str(), options.task.c_str(),
              static_cast<unsigned long long>(options.seed), stepped, options.width, options.height);
  return 0;
#endif
}

}  // namespace maps::experiments
