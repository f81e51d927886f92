#include "nn/module.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace maps::nn {

namespace {

std::string join(const std::vector<std::string>& items, std::size_t limit = 20) {
  std::string out;
  for (std::size_t i = 0; i < items.size() && i < limit; ++i) {
    if (i > 0) out += ", ";
    out += items[i];
  }
  if (items.size() > limit) out += ", ... (" + std::to_string(items.size() - limit) + " more)";
  return out;
}

std::vector<std::string> names_of(const NamedTensors& tensors) {
  std::vector<std::string> names;
  names.reserve(tensors.size());
  for (const auto& t : tensors) names.push_back(t.name);
  return names;
}

std::string describe(const ag::Tensor& t) { return ag::to_string(t.shape()) + " " + ag::to_string(t.dtype()); }

}  // namespace

Module::Module(std::string type_name) : type_name_(std::move(type_name)) {}

void Module::check_new_name(const std::string& name, const char* what) const {
  const std::string where = type_name_ + "::" + what + "(\"" + name + "\"): ";
  if (name.empty()) throw std::invalid_argument(where + "name must not be empty");
  if (name.find('.') != std::string::npos) throw std::invalid_argument(where + "name must not contain '.'");
  auto taken = [&](const auto& slots) {
    for (const auto& s : slots)
      if (s.name == name) return true;
    return false;
  };
  if (taken(parameters_) || taken(buffers_) || taken(children_))
    throw std::invalid_argument(where + "name is already used by a parameter, buffer or child of this module");
}

std::size_t Module::register_parameter(const std::string& name, ag::Tensor tensor, bool requires_grad) {
  check_new_name(name, "register_parameter");
  if (!tensor.defined())
    throw std::invalid_argument(type_name_ + "::register_parameter(\"" + name + "\"): tensor is undefined");
  if (!tensor.is_leaf())
    throw std::invalid_argument(type_name_ + "::register_parameter(\"" + name +
                                "\"): tensor must be a leaf (detach() it first)");
  tensor.requires_grad_(requires_grad);
  parameters_.push_back({name, std::move(tensor)});
  return parameters_.size() - 1;
}

std::size_t Module::register_buffer(const std::string& name, ag::Tensor tensor) {
  check_new_name(name, "register_buffer");
  if (!tensor.defined())
    throw std::invalid_argument(type_name_ + "::register_buffer(\"" + name + "\"): tensor is undefined");
  buffers_.push_back({name, tensor.detach()});
  return buffers_.size() - 1;
}

std::size_t Module::register_module(const std::string& name, std::shared_ptr<Module> child) {
  check_new_name(name, "register_module");
  if (!child) throw std::invalid_argument(type_name_ + "::register_module(\"" + name + "\"): module is null");
  children_.push_back({name, std::move(child)});
  return children_.size() - 1;
}

void Module::set_buffer(std::size_t slot, const ag::Tensor& tensor) {
  auto& current = buffers_.at(slot);
  if (tensor.shape() != current.tensor.shape() || tensor.dtype() != current.tensor.dtype())
    throw std::invalid_argument(type_name_ + "::set_buffer(\"" + current.name + "\"): expected " +
                                describe(current.tensor) + ", got " + describe(tensor));
  current.tensor = tensor.detach();
}

void Module::collect(NamedTensors& out, const std::string& prefix, bool params, bool buffers, bool recurse) const {
  if (params)
    for (const auto& p : parameters_) out.push_back({prefix + p.name, p.tensor});
  if (buffers)
    for (const auto& b : buffers_) out.push_back({prefix + b.name, b.tensor});
  if (recurse)
    for (const auto& c : children_) c.module->collect(out, prefix + c.name + ".", params, buffers, recurse);
}

NamedTensors Module::named_parameters(bool recurse) const {
  NamedTensors out;
  collect(out, "", true, false, recurse);
  return out;
}

std::vector<ag::Tensor> Module::parameters(bool recurse) const {
  std::vector<ag::Tensor> out;
  for (auto& p : named_parameters(recurse)) out.push_back(std::move(p.tensor));
  return out;
}

NamedTensors Module::named_buffers(bool recurse) const {
  NamedTensors out;
  collect(out, "", false, true, recurse);
  return out;
}

std::vector<ag::Tensor> Module::buffers(bool recurse) const {
  std::vector<ag::Tensor> out;
  for (auto& b : named_buffers(recurse)) out.push_back(std::move(b.tensor));
  return out;
}

std::vector<std::shared_ptr<Module>> Module::children() const {
  std::vector<std::shared_ptr<Module>> out;
  out.reserve(children_.size());
  for (const auto& c : children_) out.push_back(c.module);
  return out;
}

std::pair<Module*, std::size_t> Module::find_parameter_slot(const std::string& dotted_name) {
  Module* module = this;
  std::string rest = dotted_name;
  for (std::size_t dot; (dot = rest.find('.')) != std::string::npos;) {
    const std::string head = rest.substr(0, dot);
    Module* next = nullptr;
    for (const auto& c : module->children_)
      if (c.name == head) next = c.module.get();
    if (next == nullptr) break;
    module = next;
    rest = rest.substr(dot + 1);
  }
  for (std::size_t i = 0; i < module->parameters_.size(); ++i)
    if (module->parameters_[i].name == rest) return {module, i};
  throw std::out_of_range(type_name_ + ": no parameter named \"" + dotted_name +
                          "\"; parameters are: " + join(names_of(named_parameters())));
}

const ag::Tensor& Module::parameter(const std::string& dotted_name) const {
  auto [module, slot] = const_cast<Module*>(this)->find_parameter_slot(dotted_name);
  return module->parameters_[slot].tensor;
}

std::int64_t Module::parameter_count() const {
  std::int64_t n = 0;
  for (const auto& p : named_parameters()) n += p.tensor.numel();
  return n;
}

void Module::train(bool on) {
  training_ = on;
  for (auto& c : children_) c.module->train(on);
}

void Module::zero_grad() {
  for (auto& p : parameters_)
    if (p.tensor.is_leaf() && p.tensor.grad().defined()) p.tensor.set_grad(ag::Tensor());
  for (auto& c : children_) c.module->zero_grad();
}

NamedTensors Module::state_dict() const {
  NamedTensors out;
  collect(out, "", true, true, true);
  for (auto& e : out) e.tensor = e.tensor.detach();
  return out;
}

void Module::load_state_dict(const NamedTensors& state) {
  NamedTensors own;
  collect(own, "", true, true, true);
  std::unordered_map<std::string, const ag::Tensor*> given;
  std::vector<std::string> duplicated;
  for (const auto& e : state)
    if (!given.emplace(e.name, &e.tensor).second) duplicated.push_back(e.name);

  std::vector<std::string> missing, mismatched, unexpected, not_finite;
  std::unordered_map<std::string, bool> known;
  for (const auto& e : own) {
    known[e.name] = true;
    auto it = given.find(e.name);
    if (it == given.end()) {
      missing.push_back(e.name);
    } else if (!it->second->defined()) {
      mismatched.push_back(e.name + " (expected " + describe(e.tensor) + ", got an undefined tensor)");
    } else if (it->second->shape() != e.tensor.shape() || it->second->dtype() != e.tensor.dtype()) {
      mismatched.push_back(e.name + " (expected " + describe(e.tensor) + ", got " + describe(*it->second) + ")");
    } else {
      // A state from a file is untrusted: a NaN or infinity would train or act silently wrong from here on.
      const std::vector<double> values = it->second->to_vector();
      for (std::size_t i = 0; i < values.size(); ++i)
        if (!std::isfinite(values[i])) {
          not_finite.push_back(e.name + " (entry " + std::to_string(i) + ")");
          break;
        }
    }
  }
  for (const auto& e : state)
    if (!known.count(e.name)) unexpected.push_back(e.name);

  if (!missing.empty() || !unexpected.empty() || !mismatched.empty() || !duplicated.empty() || !not_finite.empty()) {
    std::ostringstream msg;
    msg << type_name_ << "::load_state_dict: state does not match the module.";
    if (!missing.empty()) msg << " Missing: " << join(missing) << ".";
    if (!unexpected.empty()) msg << " Unexpected: " << join(unexpected) << ".";
    if (!mismatched.empty()) msg << " Mismatched: " << join(mismatched) << ".";
    if (!duplicated.empty()) msg << " Given twice: " << join(duplicated) << ".";
    if (!not_finite.empty()) msg << " Not finite: " << join(not_finite) << ".";
    throw std::invalid_argument(msg.str());
  }
  ag::NoGradGuard no_grad;
  for (auto& e : own) e.tensor.copy_(*given.at(e.name));
}

void Module::to(ag::Dtype dtype) {
  ag::NoGradGuard no_grad;
  for (auto& p : parameters_) {
    if (p.tensor.dtype() == dtype) continue;
    const bool requires_grad = p.tensor.requires_grad();
    p.tensor = p.tensor.detach().to(dtype);
    p.tensor.requires_grad_(requires_grad);
  }
  for (auto& b : buffers_)
    if (b.tensor.dtype() != dtype) b.tensor = b.tensor.detach().to(dtype);
  for (auto& c : children_) c.module->to(dtype);
}

void Module::replace_parameter(const std::string& dotted_name, const ag::Tensor& tensor) {
  auto [module, slot] = find_parameter_slot(dotted_name);
  ag::Tensor& current = module->parameters_[slot].tensor;
  if (!tensor.defined())
    throw std::invalid_argument(type_name_ + "::replace_parameter(\"" + dotted_name + "\"): tensor is undefined");
  if (tensor.shape() != current.shape() || tensor.dtype() != current.dtype())
    throw std::invalid_argument(type_name_ + "::replace_parameter(\"" + dotted_name + "\"): expected " +
                                describe(current) + ", got " + describe(tensor));
  current = tensor;
}

std::shared_ptr<Module> Module::clone_impl(CloneMode mode) const {
  std::shared_ptr<Module> copy = shallow_copy();
  if (!copy) throw std::logic_error(type_name_ + "::shallow_copy returned null");
  if (mode == CloneMode::Deep) {
    ag::NoGradGuard no_grad;
    for (auto& p : copy->parameters_) {
      const bool requires_grad = p.tensor.requires_grad();
      p.tensor = p.tensor.detach().clone();
      p.tensor.requires_grad_(requires_grad);
    }
  }
  // Buffers are state, never shared, even when the parameters are.
  {
    ag::NoGradGuard no_grad;
    for (auto& b : copy->buffers_) b.tensor = b.tensor.detach().clone();
  }
  for (auto& c : copy->children_) c.module = c.module->clone_impl(mode);
  return copy;
}

std::shared_ptr<Module> Module::clone() const { return clone_impl(CloneMode::Deep); }

std::shared_ptr<Module> Module::clone_sharing_parameters() const { return clone_impl(CloneMode::ShareParameters); }

}  // namespace maps::nn
