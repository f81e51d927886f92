// Checkpoints and module files (nn::save / nn::load): any bytes either load, or are refused with an exception; a
// loaded file is then offered to a module, which takes it only if every name, shape and dtype fits.

#include <cstdint>
#include <exception>

#include "autograd/generator.h"
#include "fuzz/fuzz_util.h"
#include "nn/mlp.h"
#include "nn/serialize.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = maps::fuzz::scratch_file(data, size, ".ckpt");
  try {
    const maps::nn::Checkpoint checkpoint = maps::nn::load_tensors(path);
    static maps::ag::Generator gen(0);
    maps::nn::MLP mlp({3, 4, 2}, maps::nn::Activation::Tanh, gen);
    maps::nn::load(mlp, path);
  } catch (const std::exception&) {
  }
  return 0;
}
