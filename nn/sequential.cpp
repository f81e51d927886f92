#include "nn/sequential.h"

#include <stdexcept>

namespace maps::nn {

Sequential::Sequential(std::initializer_list<std::shared_ptr<UnaryModule>> modules) : Sequential() {
  for (const auto& m : modules) push_back(m);
}

void Sequential::push_back(std::shared_ptr<UnaryModule> module) {
  register_module(std::to_string(child_count()), std::move(module));
}

UnaryModule& Sequential::operator[](std::size_t i) const {
  if (i >= child_count())
    throw std::out_of_range("Sequential: index " + std::to_string(i) + " out of range (size " +
                            std::to_string(child_count()) + ")");
  return child_at<UnaryModule>(i);
}

ag::Tensor Sequential::forward(const ag::Tensor& x) {
  ag::Tensor y = x;
  for (std::size_t i = 0; i < child_count(); ++i) y = child_at<UnaryModule>(i).forward(y);
  return y;
}

}  // namespace maps::nn
