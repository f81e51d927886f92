#include "autograd/engine.h"

#include <algorithm>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include "autograd/grad_mode.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

namespace {

// What a pass computes gradients for: every leaf that requires grad (backward), or the given
// tensors, leaves or not (grad).
struct Targets {
  bool all_leaves = false;
  std::unordered_set<const TensorImpl*> leaves;
  std::unordered_set<const Node*> nodes;
};

Tensor accumulate(const Tensor& sum, const Tensor& term) { return sum.defined() ? add(sum, term) : term; }

std::vector<Tensor> seed_gradients(const std::vector<Tensor>& outputs, const std::vector<Tensor>& grad_outputs,
                                   const char* call) {
  if (outputs.empty()) throw std::invalid_argument(std::string(call) + ": no outputs were given");
  if (!grad_outputs.empty() && grad_outputs.size() != outputs.size()) {
    throw std::invalid_argument(std::string(call) + ": " + std::to_string(grad_outputs.size()) +
                                " grad_outputs were given for " + std::to_string(outputs.size()) + " outputs");
  }
  std::vector<Tensor> seeds(outputs.size());
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const Tensor& out = outputs[i];
    if (!out.defined())
      throw std::invalid_argument(std::string(call) + ": output " + std::to_string(i) + " is undefined");
    if (!out.requires_grad()) {
      throw std::invalid_argument(std::string(call) + ": output " + std::to_string(i) +
                                  " does not require grad and has no graph (was it made under NoGradGuard, or from "
                                  "tensors that do not require grad?)");
    }
    const Tensor given = grad_outputs.empty() ? Tensor() : grad_outputs[i];
    if (given.defined()) {
      if (given.shape() != out.shape() || given.dtype() != out.dtype()) {
        throw std::invalid_argument(std::string(call) + ": grad_output " + std::to_string(i) + " has shape " +
                                    to_string(given.shape()) + " " + to_string(given.dtype()) +
                                    " but its output has shape " + to_string(out.shape()) + " " +
                                    to_string(out.dtype()));
      }
      seeds[i] = given;
    } else {
      if (out.numel() != 1) {
        throw std::invalid_argument(std::string(call) + ": output " + std::to_string(i) + " has shape " +
                                    to_string(out.shape()) +
                                    "; a gradient can be implied only for one-element outputs, so pass grad_outputs");
      }
      seeds[i] = ones_like(out);
    }
  }
  return seeds;
}

class GraphTask {
 public:
  GraphTask(Targets targets, bool retain_graph, bool create_graph)
      : targets_(std::move(targets)), retain_graph_(retain_graph), create_graph_(create_graph) {}

  // Runs the pass; afterwards leaf_grads_ and node_grads_ hold the gradients that reached targets.
  void run(const std::vector<Tensor>& outputs, const std::vector<Tensor>& seeds) {
    std::vector<Node*> roots;
    for (std::size_t i = 0; i < outputs.size(); ++i) {
      const auto& node = outputs[i].grad_fn();
      if (node) {
        node_grads_[node.get()] = accumulate(node_grads_[node.get()], seeds[i]);
        roots.push_back(node.get());
      } else {
        add_leaf_grad(outputs[i], seeds[i]);
      }
    }
    discover(roots);
    execute(roots);
  }

  Tensor leaf_grad(const TensorImpl* leaf) const {
    auto it = leaf_grads_.find(leaf);
    return it == leaf_grads_.end() ? Tensor() : it->second;
  }
  Tensor node_grad(const Node* node) const {
    auto it = captured_.find(node);
    return it == captured_.end() ? Tensor() : it->second;
  }
  const std::unordered_map<const TensorImpl*, Tensor>& leaf_grads() const { return leaf_grads_; }
  const std::unordered_map<const TensorImpl*, Tensor>& leaf_tensors() const { return leaf_tensors_; }

 private:
  bool is_target_leaf(const Tensor& t) const {
    return t.requires_grad() && (targets_.all_leaves || targets_.leaves.count(t.impl().get()));
  }

  // Counts, for each node, how many edges lead into it. Iterative, so long chains do not overflow.
  void discover(const std::vector<Node*>& roots) {
    std::vector<Node*> stack;
    for (Node* root : roots) {
      if (dependencies_.try_emplace(root, 0).second) stack.push_back(root);
    }
    while (!stack.empty()) {
      Node* node = stack.back();
      stack.pop_back();
      for (const Tensor& input : node->inputs()) {
        if (!input.defined() || !input.grad_fn()) continue;
        auto [it, inserted] = dependencies_.try_emplace(input.grad_fn().get(), 0);
        ++it->second;
        if (inserted) stack.push_back(it->first);
      }
    }
  }

  // Orders the nodes so that each comes after every node that feeds it a gradient (Kahn), then
  // marks, walking that order backwards, the nodes whose backward leads to a target; the others
  // are skipped.
  std::vector<Node*> order(const std::vector<Node*>& roots) {
    std::unordered_map<Node*, int> remaining = dependencies_;
    std::vector<Node*> ready, sorted;
    for (Node* root : roots) {
      if (remaining[root] == 0 && std::find(ready.begin(), ready.end(), root) == ready.end()) ready.push_back(root);
    }
    while (!ready.empty()) {
      Node* node = ready.back();
      ready.pop_back();
      sorted.push_back(node);
      for (const Tensor& input : node->inputs()) {
        if (!input.defined() || !input.grad_fn()) continue;
        if (--remaining[input.grad_fn().get()] == 0) ready.push_back(input.grad_fn().get());
      }
    }
    for (auto it = sorted.rbegin(); it != sorted.rend(); ++it) {
      Node* node = *it;
      bool needed = targets_.nodes.count(node) > 0;
      for (const Tensor& input : node->inputs()) {
        if (!input.defined() || !input.requires_grad()) continue;
        if (input.grad_fn() ? needed_.count(input.grad_fn().get()) > 0 : is_target_leaf(input)) needed = true;
      }
      if (needed) needed_.insert(node);
    }
    return sorted;
  }

  void execute(const std::vector<Node*>& roots) {
    const std::vector<Node*> sorted = order(roots);
    AutoGradMode mode(create_graph_);
    for (Node* node : sorted) process(node);
  }

  void process(Node* node) {
    auto found = node_grads_.find(node);
    if (found == node_grads_.end() || !needed_.count(node)) return;
    const Tensor grad_output = found->second;
    node_grads_.erase(found);
    if (targets_.nodes.count(node)) captured_[node] = grad_output;

    const auto& inputs = node->inputs();
    std::vector<bool> needs(inputs.size(), false);
    bool any = false;
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      const Tensor& input = inputs[i];
      if (!input.defined() || !input.requires_grad()) continue;
      needs[i] = input.grad_fn() ? needed_.count(input.grad_fn().get()) > 0 : is_target_leaf(input);
      any = any || needs[i];
    }
    if (!any) return;

    std::vector<Tensor> grads = node->apply(grad_output, needs);
    if (grads.size() != inputs.size()) {
      throw std::logic_error(node->op() + ": backward returned " + std::to_string(grads.size()) + " gradients for " +
                             std::to_string(inputs.size()) + " inputs");
    }
    for (std::size_t i = 0; i < inputs.size(); ++i) {
      if (!needs[i] || !grads[i].defined()) continue;
      const Tensor& input = inputs[i];
      if (grads[i].shape() != input.shape() || grads[i].dtype() != input.dtype()) {
        throw std::logic_error(node->op() + ": backward gave input " + std::to_string(i) + " a gradient of shape " +
                               to_string(grads[i].shape()) + " " + to_string(grads[i].dtype()) +
                               " for an input of shape " + to_string(input.shape()) + " " + to_string(input.dtype()));
      }
      if (input.grad_fn()) {
        Tensor& slot = node_grads_[input.grad_fn().get()];
        slot = accumulate(slot, grads[i]);
      } else {
        add_leaf_grad(input, grads[i]);
      }
    }
    if (!retain_graph_) node->release();
  }

  void add_leaf_grad(const Tensor& leaf, const Tensor& grad) {
    if (!is_target_leaf(leaf)) return;
    const TensorImpl* key = leaf.impl().get();
    Tensor& slot = leaf_grads_[key];
    slot = accumulate(slot, grad);
    leaf_tensors_.emplace(key, leaf);
  }

  Targets targets_;
  bool retain_graph_;
  bool create_graph_;
  std::unordered_map<Node*, int> dependencies_;
  std::unordered_set<const Node*> needed_;
  std::unordered_map<const Node*, Tensor> node_grads_;
  std::unordered_map<const Node*, Tensor> captured_;
  std::unordered_map<const TensorImpl*, Tensor> leaf_grads_;
  std::unordered_map<const TensorImpl*, Tensor> leaf_tensors_;
};

}  // namespace

void backward(const std::vector<Tensor>& outputs, const std::vector<Tensor>& grad_outputs,
              std::optional<bool> retain_graph, bool create_graph) {
  const std::vector<Tensor> seeds = seed_gradients(outputs, grad_outputs, "backward");
  Targets targets;
  targets.all_leaves = true;
  GraphTask task(std::move(targets), retain_graph.value_or(create_graph), create_graph);
  task.run(outputs, seeds);

  for (const auto& entry : task.leaf_grads()) {
    const auto& key = entry.first;
    const Tensor& grad = entry.second;  // not a structured binding: clang 14 cannot capture one in a lambda
    Tensor leaf = task.leaf_tensors().at(key);
    Tensor existing = leaf.grad();
    if (create_graph) {
      // Recorded, so the stored gradient keeps its graph; cloned, because the engine may hand
      // one tensor (or the caller's grad_output) to several leaves.
      AutoGradMode recording(true);
      leaf.set_grad(existing.defined() ? add(existing, grad) : grad.clone());
    } else if (existing.defined() && !existing.requires_grad()) {
      // In place: the stored gradient is ours (a copy), and optimisers read it every step.
      dispatch_dtype(existing.dtype(), [&](auto tag) {
        using T = typename decltype(tag)::type;
        existing.array<T>() += grad.array<T>();
      });
      existing.bump_version();
    } else if (!existing.defined() && !grad.requires_grad() && grad.impl().use_count() == 1 &&
               grad.impl()->storage.use_count() == 1) {
      // A fresh tensor that nothing else holds (not another leaf's, not a view): it becomes the stored gradient
      // without a copy.
      leaf.set_grad(grad);
    } else {
      // A copy, never an alias: the engine may hand the same tensor to several leaves (add's
      // rule returns its incoming gradient), and clip_grad_norm_ scales grads in place.
      NoGradGuard no_grad;
      Tensor copy = grad.detach().clone();
      leaf.set_grad(existing.defined() ? add(existing.detach(), copy) : copy);
    }
  }
}

std::vector<Tensor> grad(const std::vector<Tensor>& outputs, const std::vector<Tensor>& inputs,
                         const std::vector<Tensor>& grad_outputs, std::optional<bool> retain_graph, bool create_graph,
                         bool allow_unused) {
  const std::vector<Tensor> seeds = seed_gradients(outputs, grad_outputs, "grad");
  if (inputs.empty()) throw std::invalid_argument("grad: no inputs were given");
  Targets targets;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const Tensor& input = inputs[i];
    if (!input.defined() || !input.requires_grad()) {
      throw std::invalid_argument("grad: input " + std::to_string(i) + " does not require grad");
    }
    if (input.grad_fn()) {
      targets.nodes.insert(input.grad_fn().get());
    } else {
      targets.leaves.insert(input.impl().get());
    }
  }
  GraphTask task(std::move(targets), retain_graph.value_or(create_graph), create_graph);
  task.run(outputs, seeds);

  std::vector<Tensor> result(inputs.size());
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const Tensor& input = inputs[i];
    result[i] = input.grad_fn() ? task.node_grad(input.grad_fn().get()) : task.leaf_grad(input.impl().get());
    if (!result[i].defined() && !allow_unused) {
      throw std::invalid_argument("grad: input " + std::to_string(i) + " (shape " + to_string(input.shape()) +
                                  ") is not used by the outputs; pass allow_unused=true to get an undefined gradient");
    }
  }
  return result;
}

}  // namespace maps::ag
