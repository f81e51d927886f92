// Checkpoints and module files (nn::save / nn::load): any bytes either load, or are refused with an exception; a
// loaded file is then offered to a module, which takes it only if every name, shape and dtype fits, and its record is
// read as best.ckpt's and as last.ckpt's (issue 41: every key checked against its range).

#include <cstdint>
#include <exception>

#include "autograd/generator.h"
#include "fuzz/fuzz_util.h"
#include "maps/training/checkpoint_record.h"
#include "nn/mlp.h"
#include "nn/serialize.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = maps::fuzz::scratch_file(data, size, ".ckpt");
  try {
    const maps::nn::Checkpoint checkpoint = maps::nn::load_tensors(path);
    try {
      maps::core::read_policy_record(checkpoint.config, path, 3);
    } catch (const std::exception&) {
    }
    try {
      maps::core::read_training_state(checkpoint.config, path);
    } catch (const std::exception&) {
    }
    static maps::ag::Generator gen(0);
    maps::nn::MLP mlp({3, 4, 2}, maps::nn::Activation::Tanh, gen);
    maps::nn::load(mlp, path);
  } catch (const std::exception&) {
  }
  return 0;
}
