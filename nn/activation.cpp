#include "nn/activation.h"

#include <stdexcept>

namespace maps::nn {

Activation activation_from_name(const std::string& name) {
  if (name == "identity") return Activation::Identity;
  if (name == "tanh") return Activation::Tanh;
  if (name == "relu") return Activation::ReLU;
  if (name == "sigmoid") return Activation::Sigmoid;
  if (name == "mish") return Activation::Mish;
  throw std::invalid_argument("unknown activation \"" + name + "\" (known: identity, tanh, relu, sigmoid, mish)");
}

std::string to_string(Activation activation) {
  switch (activation) {
    case Activation::Identity:
      return "identity";
    case Activation::Tanh:
      return "tanh";
    case Activation::ReLU:
      return "relu";
    case Activation::Sigmoid:
      return "sigmoid";
    case Activation::Mish:
      return "mish";
  }
  throw std::logic_error("to_string: invalid Activation value");
}

ag::Tensor apply_activation(Activation activation, const ag::Tensor& x) {
  switch (activation) {
    case Activation::Identity:
      return x;
    case Activation::Tanh:
      return ag::tanh(x);
    case Activation::ReLU:
      return ag::relu(x);
    case Activation::Sigmoid:
      return ag::sigmoid(x);
    case Activation::Mish:
      return ag::mish(x);
  }
  throw std::logic_error("apply_activation: invalid Activation value");
}

std::optional<ag::Fused> fused_activation(Activation activation) {
  if (activation == Activation::Tanh) return ag::Fused::Tanh;
  if (activation == Activation::Identity) return ag::Fused::None;
  return std::nullopt;
}

std::shared_ptr<UnaryModule> make_activation(Activation activation) {
  switch (activation) {
    case Activation::Identity:
      return std::make_shared<Identity>();
    case Activation::Tanh:
      return std::make_shared<Tanh>();
    case Activation::ReLU:
      return std::make_shared<ReLU>();
    case Activation::Sigmoid:
      return std::make_shared<Sigmoid>();
    case Activation::Mish:
      return std::make_shared<Mish>();
  }
  throw std::logic_error("make_activation: invalid Activation value");
}

}  // namespace maps::nn
