// parallel_mlp: a stack of parallel_linear layers run member by member, so that each member's activations and
// gradients pass from layer to layer in cache instead of through memory.
#include <algorithm>
#include <stdexcept>
#include <string>

#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/layer_kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

using detail::affine_block;
using detail::column_sums;
using detail::kRowBlock;
using detail::MatrixRef;

using Stack = detail::ParallelStack;

Stack check_stack(const Tensor& x, const std::vector<Tensor>& weights, const std::vector<Tensor>& biases) {
  detail::check_defined(x, "parallel_mlp", "input");
  if (weights.empty()) throw std::invalid_argument("parallel_mlp: needs at least one layer");
  if (!biases.empty() && biases.size() != weights.size())
    throw std::invalid_argument("parallel_mlp: " + std::to_string(biases.size()) + " biases for " +
                                std::to_string(weights.size()) + " layers (give one per layer, or none)");
  Stack s{};
  for (std::size_t l = 0; l < weights.size(); ++l) {
    const Tensor& w = weights[l];
    detail::check_defined(w, "parallel_mlp", "weight");
    detail::check_same_dtype(x, w, "parallel_mlp");
    if (w.dim() != 3)
      throw std::invalid_argument("parallel_mlp: weight " + std::to_string(l) + " must be [members, in, out], got " +
                                  to_string(w.shape()));
    if (l == 0) {
      s.members = w.size(0);
      s.widths.push_back(w.size(1));
    } else if (w.size(0) != s.members || w.size(1) != s.widths.back()) {
      throw std::invalid_argument("parallel_mlp: weight " + std::to_string(l) + " " + to_string(w.shape()) +
                                  " does not follow [" + std::to_string(s.members) + ", ., " +
                                  std::to_string(s.widths.back()) + "]");
    }
    s.widths.push_back(w.size(2));
    if (!biases.empty()) {
      detail::check_defined(biases[l], "parallel_mlp", "bias");
      detail::check_same_dtype(x, biases[l], "parallel_mlp");
      if (biases[l].shape() != Shape{s.members, 1, w.size(2)})
        throw std::invalid_argument("parallel_mlp: bias " + std::to_string(l) + " of shape " +
                                    to_string(biases[l].shape()) + " does not match weight " + to_string(w.shape()));
    }
  }
  s.shared = x.dim() == 2 && x.size(1) == s.widths[0];
  if (!s.shared && !(x.dim() == 3 && x.size(0) == s.members && x.size(2) == s.widths[0]))
    throw std::invalid_argument("parallel_mlp: input of shape " + to_string(x.shape()) + " does not fit weight " +
                                to_string(weights[0].shape()));
  s.rows = x.size(-2);
  s.layers = static_cast<std::int64_t>(weights.size());
  s.has_bias = !biases.empty();
  return s;
}

// The same gradients as ops (create_graph, or a shared input's gradient): the stack is run again as parallel_linear
// ops so its outputs are on the graph, then the chain rule is written with ops.
Grads recorded_gradients(const Stack& s, const Tensor& g, const Tensor& x, const std::vector<Tensor>& weights,
                         const std::vector<Tensor>& biases, Fused activation, const Needs& need) {
  std::vector<Tensor> outputs;
  Tensor h = x;
  for (std::size_t l = 0; l < weights.size(); ++l) {
    h = parallel_linear(h, weights[l], s.has_bias ? biases[l] : Tensor(), activation);
    outputs.push_back(h);
  }
  const std::size_t per_layer = s.has_bias ? 2 : 1;
  Grads grads(1 + per_layer * weights.size());
  Tensor grad_out = g;
  for (std::int64_t l = s.layers - 1; l >= 0; --l) {
    const std::size_t slot = 1 + per_layer * static_cast<std::size_t>(l);
    const Tensor gz =
        activation == Fused::Tanh ? tanh_backward(grad_out, outputs[static_cast<std::size_t>(l)]) : grad_out;
    if (s.has_bias && need[slot + 1]) grads[slot + 1] = sum(gz, {1}, true);
    const Tensor input =
        l > 0 ? outputs[static_cast<std::size_t>(l - 1)] : (s.shared ? expand(x, {s.members, s.rows, s.widths[0]}) : x);
    if (need[slot]) grads[slot] = gemm(input, gz, true, false);
    if (l > 0 || need[0]) grad_out = gemm(gz, weights[static_cast<std::size_t>(l)], false, true);
  }
  if (need[0]) grads[0] = s.shared ? sum(grad_out, {0}) : grad_out;
  return grads;
}

}  // namespace

namespace detail {

void parallel_stack_forward(const ParallelStack& s, const Tensor& x, const std::vector<Tensor>& weights,
                            const std::vector<Tensor>& biases, Fused activation, std::vector<Tensor> outputs) {
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    std::int64_t work = 0;
    for (std::int64_t l = 0; l < s.layers; ++l) work += s.members * s.rows * s.widths[l] * s.widths[l + 1];
    parallel_for(s.members, work < detail::kParallelGemmWork ? s.members : 1, [&](std::int64_t m0, std::int64_t m1) {
      for (std::int64_t m = m0; m < m1; ++m) {
        for (std::int64_t l = 0; l < s.layers; ++l) {
          const std::int64_t in = s.widths[l], out = s.widths[l + 1];
          const T* input = l == 0 ? x.data<T>() + (s.shared ? 0 : m * s.rows * in)
                                  : outputs[static_cast<std::size_t>(l - 1)].data<T>() + m * s.rows * in;
          const T* bias = s.has_bias ? biases[static_cast<std::size_t>(l)].data<T>() + m * out : nullptr;
          for (std::int64_t r0 = 0; r0 < s.rows; r0 += kRowBlock) {
            const std::int64_t r1 = std::min(s.rows, r0 + kRowBlock);
            affine_block<T>({input + r0 * in, r1 - r0, in, in},
                            {weights[static_cast<std::size_t>(l)].data<T>() + m * in * out, in, out, out}, false, bias,
                            activation, outputs[static_cast<std::size_t>(l)].data<T>() + m * s.rows * out + r0 * out,
                            r1 - r0, out);
          }
        }
      }
    });
  });
}

Grads parallel_stack_gradients(const ParallelStack& s, const Tensor& g, const Tensor& x,
                               const std::vector<Tensor>& weights, const std::vector<Tensor>& outputs, Fused activation,
                               const Needs& need) {
  const std::size_t per_layer = s.has_bias ? 2 : 1;
  Grads grads(1 + per_layer * static_cast<std::size_t>(s.layers));
  if (need[0]) grads[0] = empty({s.members, s.rows, s.widths[0]}, x.dtype());
  for (std::int64_t l = 0; l < s.layers; ++l) {
    const std::size_t slot = 1 + per_layer * static_cast<std::size_t>(l);
    if (need[slot]) grads[slot] = empty(weights[static_cast<std::size_t>(l)].shape(), x.dtype());
    if (s.has_bias && need[slot + 1]) grads[slot + 1] = empty({s.members, 1, s.widths[l + 1]}, x.dtype());
  }
  const std::int64_t widest = *std::max_element(s.widths.begin(), s.widths.end());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    parallel_for(s.members, 1, [&](std::int64_t m0, std::int64_t m1) {
      RowMatrix<T> upper(s.rows, widest), lower(s.rows, widest);  // gradient at a layer's output, then its input
      for (std::int64_t m = m0; m < m1; ++m) {
        const T* grad_out = g.data<T>() + m * s.rows * s.widths.back();
        for (std::int64_t l = s.layers - 1; l >= 0; --l) {
          const std::int64_t in = s.widths[l], out = s.widths[l + 1], count = s.rows * out;
          const std::size_t slot = 1 + per_layer * static_cast<std::size_t>(l);
          // The gradient before the activation: computed into the scratch block (over grad_out when that is the
          // scratch block: the same index is read and written), or grad_out itself without an activation.
          const T* gz = grad_out;
          if (activation == Fused::Tanh) {
            const Eigen::Map<const Array> y(outputs[static_cast<std::size_t>(l)].data<T>() + m * count, count);
            Eigen::Map<Array>(upper.data(), count) = Eigen::Map<const Array>(grad_out, count) * (T(1) - y * y);
            gz = upper.data();
          }
          const MatrixRef<const T> gz_m{gz, s.rows, out, out};
          if (s.has_bias && grads[slot + 1].defined())
            column_sums<T>(gz, s.rows, out, grads[slot + 1].data<T>() + m * out);
          const T* input = l == 0 ? x.data<T>() + (s.shared ? 0 : m * s.rows * in)
                                  : outputs[static_cast<std::size_t>(l - 1)].data<T>() + m * s.rows * in;
          if (grads[slot].defined())
            detail::gemm_serial<T>({input, s.rows, in, in}, true, gz_m, false,
                                   {grads[slot].data<T>() + m * in * out, in, out, out}, false);
          if (l > 0 || grads[0].defined()) {
            T* below = l > 0 ? lower.data() : grads[0].data<T>() + m * s.rows * in;
            detail::gemm_serial<T>(gz_m, false,
                                   {weights[static_cast<std::size_t>(l)].data<T>() + m * in * out, in, out, out}, true,
                                   {below, s.rows, in, in}, false);
            grad_out = below;
            std::swap(upper, lower);
          }
        }
      }
    });
  });
  return grads;
}

}  // namespace detail

Tensor parallel_mlp(const Tensor& x, const std::vector<Tensor>& weights, const std::vector<Tensor>& biases,
                    Fused activation) {
  const Stack s = check_stack(x, weights, biases);
  std::vector<Tensor> outputs;
  for (std::int64_t l = 0; l < s.layers; ++l) outputs.push_back(empty({s.members, s.rows, s.widths[l + 1]}, x.dtype()));
  detail::parallel_stack_forward(s, x, weights, biases, activation, outputs);
  std::vector<Tensor> inputs{x};
  for (std::size_t l = 0; l < weights.size(); ++l) {
    inputs.push_back(weights[l]);
    if (s.has_bias) inputs.push_back(biases[l]);
  }
  // The hidden outputs are kept for the backward pass; the last one is the op's own output.
  std::vector<Tensor> hidden(outputs.begin(), outputs.end() - 1);
  return record(
      activation == Fused::Tanh ? "parallel_mlp_tanh" : "parallel_mlp", outputs.back(), inputs,
      [s, x, weights, biases, hidden, activation](const Tensor& g, const Needs& need, Node& self) {
        if (GradMode::is_enabled() || (s.shared && need[0]))
          return recorded_gradients(s, g, x, weights, biases, activation, need);
        std::vector<Tensor> all = hidden;
        all.push_back(self.output());
        return detail::parallel_stack_gradients(s, g, x, weights, all, activation, need);
      },
      true);
}

}  // namespace maps::ag
