#pragma once

#include <cstdint>
#include <string>

namespace maps::experiments {

// `maps render`: one frame of a task's scene, drawn offscreen with MuJoCo's renderer (OSMesa) into a PNG, after
// `steps` steps of the task's expert from the initial state of `seed`. With `run`: a strip of `frames` frames spread
// over one episode of that trained run's policy on the task (MAPS with `module` >= 0: its selector forced onto
// that one module, the paper's Fig. 6 right); with an --out ending in .gif, the whole episode animated.
struct RenderOptions {
  std::string task;
  std::uint64_t seed = 0;
  std::string out;
  int steps = 0;
  int width = 640;
  int height = 480;
  std::string camera;       // a named camera of the model; empty: a view chosen for the task
  std::string run;          // a run folder (maps train): render its policy instead of the expert
  int module = -1;          // with run, a MAPS run: every score on this module
  int frames = 5;           // with run: frames in the strip
  int every = 0;            // with run and a .gif --out: a frame every this many steps (0: about 150 frames)
  bool seed_given = false;  // with run and no --seed: the first evaluation seed (held out from the demonstrations)
};

// The strip of a trained run's episode (run_render calls it when options.run is set; built with the renderer).
int run_render_policy(const RenderOptions& options);

int run_render(const RenderOptions& options);

}  // namespace maps::experiments
