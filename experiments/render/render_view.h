#pragma once

#ifdef MAPS_HAVE_RENDER
#include "envs/mujoco_env.h"
#include "envs/render/offscreen_renderer.h"

namespace maps::experiments {

// The view `maps render` takes of a task when no camera is named: MT10's table from the robot's left front,
// HalfCheetah from the side following its torso.
envs::CameraView default_view(const envs::MujocoEnv& env);

}  // namespace maps::experiments
#endif
