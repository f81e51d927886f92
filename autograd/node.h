#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "autograd/tensor.h"

namespace maps::ag {

class Node;

// Which inputs a backward rule reads the values of (the rest it only routes gradients to): those are checked for
// in-place changes before the rule runs.
struct Reads {
  enum class Kind { All, None } kind = Kind::All;
  static Reads all() { return {Kind::All}; }
  static Reads none() { return {Kind::None}; }
};

// A backward rule: given the gradient of the node's output and which inputs need a gradient,
// returns one gradient per input (undefined where not needed). Rules are written with Tensor
// ops, so running them with grad mode on records the graph of the gradient (create_graph).
using BackwardFn =
    std::function<std::vector<Tensor>(const Tensor& grad_output, const std::vector<bool>& needs_grad, Node& self)>;

// One recorded op. The graph is implicit: a node holds the input tensors it differentiates
// towards, and each non-leaf input holds the node that made it.
class Node : public std::enable_shared_from_this<Node> {
 public:
  Node(std::string op, std::vector<Tensor> inputs, BackwardFn backward, Reads reads = Reads::all());
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  const std::string& op() const { return op_; }
  const std::vector<Tensor>& inputs() const { return inputs_; }
  bool released() const { return released_; }

  // Keeps the output's values so the rule can use them (tanh, exp, softmax) without a
  // reference cycle; output() rebuilds the output as a tensor whose grad_fn is this node.
  void save_output(const Tensor& output);
  Tensor output();

  // Throws, naming the op and the tensor, when an input the rule reads or the saved output was changed in place
  // since the op ran.
  std::vector<Tensor> apply(const Tensor& grad_output, const std::vector<bool>& needs_grad);
  // Frees the saved tensors after a backward pass without retain_graph.
  void release();

 private:
  std::string op_;
  std::vector<Tensor> inputs_;
  BackwardFn backward_;
  Shape output_shape_;
  Dtype output_dtype_ = Dtype::Float32;
  std::shared_ptr<Storage> output_storage_;
  std::uint64_t output_version_ = 0;
  std::vector<std::uint64_t> input_versions_;  // empty when the rule reads no input
  bool released_ = false;
};

// Wraps a freshly computed result: when grad mode is on and any input requires grad, records
// a node named `op` and marks the result as requiring grad. Returns `result`.
Tensor record(const char* op, Tensor result, std::vector<Tensor> inputs, BackwardFn backward, bool save_output = false,
              Reads reads = Reads::all());

// True when grad mode is on and some input requires grad (so an op should record).
bool any_requires_grad(const std::vector<Tensor>& inputs);

}  // namespace maps::ag
