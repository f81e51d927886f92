#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "nn/activation.h"
#include "nn/module.h"

namespace maps::nn {

class Linear;

// Linear layers of sizes {in, h1, ..., out} with an activation between them (and after the last one when
// activate_last). Parameters are "layers.0.weight", "layers.0.bias", "layers.1.weight", ...; layers are
// initialised in order from `gen`, each like a Linear.
class MLP : public UnaryModule {
 public:
  MLP(const std::vector<std::int64_t>& sizes, Activation activation, ag::Generator& gen, bool activate_last = false);
  // activation: "identity" | "tanh" | "relu" | "sigmoid" | "mish".
  MLP(const std::vector<std::int64_t>& sizes, const std::string& activation, ag::Generator& gen,
      bool activate_last = false);

  // x [B, sizes.front()] -> [B, sizes.back()] (or [b, n, ...] -> [b, n, ...]).
  ag::Tensor forward(const ag::Tensor& x) override;
  // The layers from `first` on (with their activations), for a caller that computed the earlier ones itself.
  ag::Tensor forward_from(std::size_t first, const ag::Tensor& x);
  // Layer i (0-based).
  Linear& layer(std::size_t i);

  const std::vector<std::int64_t>& sizes() const { return sizes_; }
  Activation activation() const { return activation_; }
  bool activate_last() const { return activate_last_; }
  std::size_t num_layers() const { return sizes_.size() - 1; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<MLP>(*this); }

 private:
  std::vector<std::int64_t> sizes_;
  Activation activation_;
  bool activate_last_;
  std::size_t layers_ = 0;
};

}  // namespace maps::nn
