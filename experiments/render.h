#pragma once

#include <cstdint>
#include <string>

namespace maps::experiments {

// `maps render`: one frame of a task's scene, drawn offscreen with MuJoCo's renderer (OSMesa) into a PNG, after
// `steps` steps of the task's expert from the initial state of `seed`.
struct RenderOptions {
  std::string task;
  std::uint64_t seed = 0;
  std::string out;
  int steps = 0;
  int width = 640;
  int height = 480;
  std::string camera;  // a named camera of the model; empty: a view chosen for the task
};

int run_render(const RenderOptions& options);

}  // namespace maps::experiments
