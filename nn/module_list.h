#pragma once

#include <cstddef>
#include <memory>

#include "nn/module.h"

namespace maps::nn {

// Holds modules registered as "0", "1", ... without calling them; the owner decides how (MLP's "layers").
class ModuleList : public Module {
 public:
  ModuleList() : Module("ModuleList") {}

  void push_back(std::shared_ptr<Module> module);
  std::size_t size() const { return child_count(); }
  Module& operator[](std::size_t i) const;
  // The module at i as the type it was pushed as (unchecked).
  template <typename M>
  M& at(std::size_t i) const {
    check_index(i);
    return child_at<M>(i);
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ModuleList>(*this); }

 private:
  void check_index(std::size_t i) const;
};

}  // namespace maps::nn
