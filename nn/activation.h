#pragma once

#include <memory>
#include <optional>
#include <string>

#include "nn/module.h"

namespace maps::nn {

// Parameter-free activation modules, for Sequential. MLP applies the same functions without modules.
class Tanh : public UnaryModule {
 public:
  Tanh() : UnaryModule("Tanh") {}
  ag::Tensor forward(const ag::Tensor& x) override { return ag::tanh(x); }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<Tanh>(*this); }
};

class ReLU : public UnaryModule {
 public:
  ReLU() : UnaryModule("ReLU") {}
  ag::Tensor forward(const ag::Tensor& x) override { return ag::relu(x); }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ReLU>(*this); }
};

class Sigmoid : public UnaryModule {
 public:
  Sigmoid() : UnaryModule("Sigmoid") {}
  ag::Tensor forward(const ag::Tensor& x) override { return ag::sigmoid(x); }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<Sigmoid>(*this); }
};

class Mish : public UnaryModule {
 public:
  Mish() : UnaryModule("Mish") {}
  ag::Tensor forward(const ag::Tensor& x) override { return ag::mish(x); }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<Mish>(*this); }
};

class Identity : public UnaryModule {
 public:
  Identity() : UnaryModule("Identity") {}
  ag::Tensor forward(const ag::Tensor& x) override { return x; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<Identity>(*this); }
};

enum class Activation { Identity, Tanh, ReLU, Sigmoid, Mish };

// "identity" | "tanh" | "relu" | "sigmoid" | "mish"; anything else throws listing the valid names.
Activation activation_from_name(const std::string& name);
std::string to_string(Activation activation);
// Applies the activation as a function (no module).
ag::Tensor apply_activation(Activation activation, const ag::Tensor& x);
// The activation as the layer ops can run it in their own pass (ag::Fused), or nullopt when they cannot (ReLU,
// sigmoid: the layer's output then goes through apply_activation).
std::optional<ag::Fused> fused_activation(Activation activation);
// The activation as a module.
std::shared_ptr<UnaryModule> make_activation(Activation activation);

}  // namespace maps::nn
