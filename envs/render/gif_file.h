#pragma once

#include <string>
#include <vector>

#include "envs/render/offscreen_renderer.h"

namespace maps::envs {

// Writes the frames as a looping animated GIF (giflib), each frame quantised to its own 256-colour palette, shown
// for `delay_centiseconds`. All frames must have the first frame's size. Written to a temporary in the same folder,
// then renamed. Throws naming the file on failure.
void write_gif(const std::string& path, const std::vector<Image>& frames, int delay_centiseconds);

}  // namespace maps::envs
