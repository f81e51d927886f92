#include "autograd/node.h"

#include <stdexcept>

#include "autograd/grad_mode.h"

namespace maps::ag {

Node::Node(std::string op, std::vector<Tensor> inputs, BackwardFn backward, Reads reads)
    : op_(std::move(op)), inputs_(std::move(inputs)), backward_(std::move(backward)) {
  if (reads.kind == Reads::Kind::All) {
    input_versions_.reserve(inputs_.size());
    for (const Tensor& t : inputs_) input_versions_.push_back(t.defined() ? t.impl()->storage->version() : 0);
  }
}

Node::~Node() {
  // Tearing down a long chain recursively (tensor -> node -> tensor ...) would overflow the
  // stack, so nodes that only this chain owns are unlinked one at a time.
  std::vector<std::shared_ptr<Node>> pending;
  auto unlink = [&pending](Node& node) {
    node.backward_ = nullptr;
    for (Tensor& input : node.inputs_) {
      std::shared_ptr<TensorImpl> impl = input.impl();
      input = Tensor();
      if (impl && impl.use_count() == 1 && impl->grad_fn && impl->grad_fn.use_count() == 1) {
        pending.push_back(std::move(impl->grad_fn));
      }
    }
    node.inputs_.clear();
  };
  unlink(*this);
  while (!pending.empty()) {
    std::shared_ptr<Node> node = std::move(pending.back());
    pending.pop_back();
    unlink(*node);
  }
}

void Node::save_output(const Tensor& output) {
  output_shape_ = output.shape();
  output_dtype_ = output.dtype();
  output_storage_ = output.impl()->storage;
  output_version_ = output_storage_->version();
}

Tensor Node::output() {
  if (!output_storage_) {
    throw std::logic_error(op_ + ": the backward rule asked for the output, which was not saved or was freed");
  }
  auto impl = std::make_shared<TensorImpl>();
  impl->shape = output_shape_;
  impl->dtype = output_dtype_;
  impl->storage = output_storage_;
  impl->requires_grad = true;
  impl->grad_fn = shared_from_this();
  return Tensor(impl);
}

std::vector<Tensor> Node::apply(const Tensor& grad_output, const std::vector<bool>& needs_grad) {
  if (released_) {
    throw std::runtime_error(
        "backward: trying to go through the graph of '" + op_ +
        "' a second time, but its saved tensors were freed after the first pass; pass retain_graph=true to the "
        "first backward or grad call if you need to go through it again");
  }
  for (std::size_t i = 0; i < input_versions_.size(); ++i) {
    const Tensor& t = inputs_[i];
    if (t.defined() && t.impl()->storage->version() != input_versions_[i])
      throw std::runtime_error("backward: input " + std::to_string(i) + " of '" + op_ + "' (" + to_string(t.shape()) +
                               " " + to_string(t.dtype()) + ") was changed in place after '" + op_ +
                               "' used it (version " + std::to_string(t.impl()->storage->version()) + ", saved at " +
                               std::to_string(input_versions_[i]) +
                               "), so its gradient would use the new values; "
                               "change a clone instead, or run the backward pass before the change");
  }
  if (output_storage_ && output_storage_->version() != output_version_)
    throw std::runtime_error("backward: the output of '" + op_ + "' (" + to_string(output_shape_) + " " +
                             to_string(output_dtype_) + ") was changed in place after '" + op_ +
                             "' computed it (version " + std::to_string(output_storage_->version()) + ", saved at " +
                             std::to_string(output_version_) +
                             "), and its gradient is computed from it; "
                             "change a clone instead");
  return backward_(grad_output, needs_grad, *this);
}

void Node::release() {
  released_ = true;
  backward_ = nullptr;
  output_storage_.reset();
}

bool any_requires_grad(const std::vector<Tensor>& inputs) {
  if (!GradMode::is_enabled()) return false;
  for (const Tensor& t : inputs) {
    if (t.defined() && t.requires_grad()) return true;
  }
  return false;
}

Tensor record(const char* op, Tensor result, std::vector<Tensor> inputs, BackwardFn backward, bool save_output,
              Reads reads) {
  if (!any_requires_grad(inputs)) return result;
  auto node = std::make_shared<Node>(op, std::move(inputs), std::move(backward), reads);
  if (save_output) node->save_output(result);
  result.impl()->requires_grad = true;
  result.impl()->grad_fn = std::move(node);
  return result;
}

}  // namespace maps::ag
