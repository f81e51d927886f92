#pragma once

#include <cstddef>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "nn/module.h"

namespace maps::nn {

// Chains unary modules, registered as children "0", "1", ... (parameter names "0.weight", "2.bias").
class Sequential : public UnaryModule {
 public:
  Sequential() : UnaryModule("Sequential") {}
  Sequential(std::initializer_list<std::shared_ptr<UnaryModule>> modules);

  void push_back(std::shared_ptr<UnaryModule> module);
  std::size_t size() const { return child_count(); }
  UnaryModule& operator[](std::size_t i) const;

  ag::Tensor forward(const ag::Tensor& x) override;

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<Sequential>(*this); }
};

}  // namespace maps::nn
