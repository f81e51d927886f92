#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "autograd/autograd.h"

namespace maps::nn {

struct NamedTensor {
  std::string name;
  ag::Tensor tensor;
};
// Ordered (insertion order, parents before children) list of named tensors, like LibTorch's OrderedDict.
using NamedTensors = std::vector<NamedTensor>;

class Module;

struct NamedModule {
  std::string name;
  std::shared_ptr<Module> module;
};

// Base of every layer, after torch::nn::Module.
//
// Reference semantics: modules are held by std::shared_ptr (std::make_shared<Linear>(...)); copying the
// shared_ptr aliases the module, clone() makes an independent deep copy. There is no holder macro.
//
// Slots: parameters, buffers and children live only in this base, in insertion order. A subclass keeps the
// slot index that register_* returns (never a copy of the tensor or of the child pointer) and reads the slot
// on every forward, through parameter_at(i) / child_at<M>(i). That is what lets replace_parameter() (MAML's
// adapted weights), to(dtype), load_state_dict() and clone() work on any module without its help.
//
// A subclass is copyable (its members are configuration and slot indices) and implements
// shallow_copy() as `return std::make_shared<Self>(*this);` so clone() can rebuild it.
class Module {
 public:
  explicit Module(std::string type_name);
  virtual ~Module() = default;
  Module& operator=(const Module&) = delete;

  // The class name ("Linear"), used in error messages.
  const std::string& type_name() const { return type_name_; }

  // ----- tree queries -----
  // Dotted names ("layers.1.weight"), own slots first, then each child's in registration order.
  NamedTensors named_parameters(bool recurse = true) const;
  std::vector<ag::Tensor> parameters(bool recurse = true) const;
  NamedTensors named_buffers(bool recurse = true) const;
  std::vector<ag::Tensor> buffers(bool recurse = true) const;
  const std::vector<NamedModule>& named_children() const { return children_; }
  std::vector<std::shared_ptr<Module>> children() const;
  // The parameter at a dotted name; throws naming it (and listing the valid names) when absent.
  const ag::Tensor& parameter(const std::string& dotted_name) const;
  std::int64_t parameter_count() const;  // total number of scalars in all parameters

  // ----- modes and gradients -----
  virtual void train(bool on = true);  // recursive; override to react, but call the base
  void eval() { train(false); }
  bool is_training() const { return training_; }
  // Sets every parameter's grad to undefined (LibTorch's set_to_none=true).
  void zero_grad();

  // ----- state -----
  // Parameters then buffers, by dotted name, detached (they share storage with the module).
  NamedTensors state_dict() const;
  // Copies values in. Every module name must appear in `state` with the same shape and dtype, and `state` may
  // hold no other name; otherwise throws listing every missing / unexpected / mismatched entry.
  void load_state_dict(const NamedTensors& state);
  // Converts every parameter and buffer (recursively) to `dtype`; parameters stay leaves with their
  // requires_grad, and grads are dropped. Optimisers built on the old parameters must be rebuilt.
  void to(ag::Dtype dtype);

  // ----- meta-learning -----
  // Puts `tensor` (typically a non-leaf such as theta - a*g) in the parameter slot at `dotted_name`, so the next
  // forward uses it. Shape and dtype must match the current slot.
  void replace_parameter(const std::string& dotted_name, const ag::Tensor& tensor);
  // Deep copy: every parameter and buffer is a new leaf holding a copy of the values (same requires_grad);
  // children are cloned recursively. Gradients of the copy never reach this module.
  std::shared_ptr<Module> clone() const;
  // Copies the module tree, but the copy's parameter slots hold this module's own tensors (learn2learn's
  // clone_module without the identity op). replace_parameter() on the copy leaves this module untouched, and
  // gradients taken through the copy's adapted parameters flow back to this module's parameters.
  std::shared_ptr<Module> clone_sharing_parameters() const;

 protected:
  Module(const Module&) = default;

  // Name: non-empty, no '.', unique among this module's parameters, buffers and children. The tensor must be a
  // defined leaf; its requires_grad is set to `requires_grad`. Returns the slot index.
  std::size_t register_parameter(const std::string& name, ag::Tensor tensor, bool requires_grad = true);
  // A tensor saved with the state but never trained (running statistics, normalisers).
  std::size_t register_buffer(const std::string& name, ag::Tensor tensor);
  std::size_t register_module(const std::string& name, std::shared_ptr<Module> child);

  const ag::Tensor& parameter_at(std::size_t slot) const { return parameters_[slot].tensor; }
  const ag::Tensor& buffer_at(std::size_t slot) const { return buffers_[slot].tensor; }
  // The child at `slot`, as the type it was registered with (unchecked static cast).
  template <typename M>
  M& child_at(std::size_t slot) const {
    return static_cast<M&>(*children_[slot].module);
  }
  std::size_t child_count() const { return children_.size(); }
  // Overwrites a buffer slot (same shape and dtype); for modules that update running statistics.
  void set_buffer(std::size_t slot, const ag::Tensor& tensor);

  // A copy of the most-derived object sharing every slot (see the class comment).
  virtual std::shared_ptr<Module> shallow_copy() const = 0;

 private:
  enum class CloneMode { Deep, ShareParameters };
  std::shared_ptr<Module> clone_impl(CloneMode mode) const;
  void check_new_name(const std::string& name, const char* what) const;
  // The module owning the slot named by `dotted_name` and the slot's index, or throws.
  std::pair<Module*, std::size_t> find_parameter_slot(const std::string& dotted_name);
  void collect(NamedTensors& out, const std::string& prefix, bool params, bool buffers, bool recurse) const;

  std::string type_name_;
  std::vector<NamedTensor> parameters_;
  std::vector<NamedTensor> buffers_;
  std::vector<NamedModule> children_;
  bool training_ = true;
};

// clone() keeping the static type: auto copy = nn::clone(linear);  // std::shared_ptr<Linear>
template <typename M>
std::shared_ptr<M> clone(const std::shared_ptr<M>& module) {
  return std::static_pointer_cast<M>(module->clone());
}
template <typename M>
std::shared_ptr<M> clone_sharing_parameters(const std::shared_ptr<M>& module) {
  return std::static_pointer_cast<M>(module->clone_sharing_parameters());
}

// A module with one input and one output; Sequential chains these.
class UnaryModule : public Module {
 public:
  using Module::Module;
  virtual ag::Tensor forward(const ag::Tensor& x) = 0;
  ag::Tensor operator()(const ag::Tensor& x) { return forward(x); }

 protected:
  UnaryModule(const UnaryModule&) = default;
};

}  // namespace maps::nn
