// `maps render`: a task's scene, or a trained policy's episode, drawn offscreen.

#include "experiments/render/render.h"

#include <memory>

#include "experiments/cli/command.h"
#include "experiments/cli/options.h"

namespace maps::experiments::cli {

void add_render(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<RenderOptions>();
  CLI::App* command =
      tool.add_subcommand("render",
                          "Draw a task's scene offscreen (MuJoCo's renderer on OSMesa) to PNG, or a trained policy's "
                          "episode to a PNG strip or an animated GIF");
  command->add_option("--task", options->task, "Task name, e.g. mt10/door-open or gravity/1.0")->required();
  CLI::Option* seed =
      add_seed(command, options->seed, "Seed of the initial state (with --run: default the first evaluation seed)");
  command->add_option("--out", options->out, "PNG file to write (with --run, a .gif name: the episode animated)")
      ->required();
  add_non_negative(command, "--steps", options->steps, "Steps of the task's expert before the picture");
  add_positive(command, "--width", options->width, "Width in pixels (at most 640)");
  add_positive(command, "--height", options->height, "Height in pixels (at most 480)");
  command->add_option("--camera", options->camera, "A named camera of the model (default: a view made for the task)");
  command
      ->add_option("--run", options->run,
                   "A trained run folder: a strip of frames of its policy's episode instead of the expert")
      ->check(CLI::ExistingDirectory);
  command->add_option("--module", options->module, "With --run of MAPS: every selector score on this module")
      ->check(non_negative());
  add_non_negative(command, "--every", options->every,
                   "With --run and --out x.gif: a frame every N steps (0: about 150 frames in all)");
  add_positive(command, "--frames", options->frames, "With --run: frames in the strip, spread over the episode");
  commands.push_back({command, [options, seed] {
                        options->seed_given = seed->count() > 0;
                        return run_render(*options);
                      }});
}

}  // namespace maps::experiments::cli
