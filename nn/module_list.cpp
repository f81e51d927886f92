#include "nn/module_list.h"

#include <stdexcept>
#include <string>

namespace maps::nn {

void ModuleList::push_back(std::shared_ptr<Module> module) {
  register_module(std::to_string(child_count()), std::move(module));
}

void ModuleList::check_index(std::size_t i) const {
  if (i >= child_count())
    throw std::out_of_range("ModuleList: index " + std::to_string(i) + " out of range (size " +
                            std::to_string(child_count()) + ")");
}

Module& ModuleList::operator[](std::size_t i) const {
  check_index(i);
  return child_at<Module>(i);
}

}  // namespace maps::nn
