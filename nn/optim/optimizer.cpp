#include "nn/optim/optimizer.h"

#include <stdexcept>
#include <string>

namespace maps::optim {

Optimizer::Optimizer(std::vector<ag::Tensor> params, const char* name) : name_(name), params_(std::move(params)) {
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const ag::Tensor& p = params_[i];
    if (!p.defined())
      throw std::invalid_argument(std::string(name_) + ": parameter " + std::to_string(i) + " is undefined");
    if (!p.is_leaf())
      throw std::invalid_argument(std::string(name_) + ": parameter " + std::to_string(i) + " (shape " +
                                  ag::to_string(p.shape()) + ") is not a leaf; optimisers update leaves in place");
    for (std::size_t j = 0; j < i; ++j)
      if (params_[j].impl() == p.impl())
        throw std::invalid_argument(std::string(name_) + ": parameter " + std::to_string(i) +
                                    " is the same tensor as parameter " + std::to_string(j));
  }
}

void Optimizer::zero_grad() {
  for (auto& p : params_)
    if (p.grad().defined()) p.set_grad(ag::Tensor());
}

ag::Tensor Optimizer::checked_grad(std::size_t i) const {
  const ag::Tensor& p = params_[i];
  ag::Tensor g = p.grad();
  if (!g.defined()) return g;
  if (g.shape() != p.shape() || g.dtype() != p.dtype())
    throw std::invalid_argument(std::string(name_) + ": parameter " + std::to_string(i) + " is " +
                                ag::to_string(p.shape()) + " " + ag::to_string(p.dtype()) + " but its grad is " +
                                ag::to_string(g.shape()) + " " + ag::to_string(g.dtype()));
  return g;
}

}  // namespace maps::optim
