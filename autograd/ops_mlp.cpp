// mlp: a stack of linear layers run block of rows by block of rows, so that each block's activations and gradients
// pass from layer to layer in cache instead of through memory.
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

using Layers = detail::LinearStack;

Layers check_layers(const Tensor& x, const std::vector<Tensor>& weights, const std::vector<Tensor>& biases,
                    Fused hidden, Fused last) {
  detail::check_defined(x, "mlp", "input");
  if (weights.empty()) throw std::invalid_argument("mlp: needs at least one layer");
  if (!biases.empty() && biases.size() != weights.size())
    throw std::invalid_argument("mlp: " + std::to_string(biases.size()) + " biases for " +
                                std::to_string(weights.size()) + " layers (give one per layer, or none)");
  if (x.dim() != 2) throw std::invalid_argument("mlp: input must be [rows, in], got " + to_string(x.shape()));
  Layers s{};
  s.widths.push_back(x.size(1));
  for (std::size_t l = 0; l < weights.size(); ++l) {
    const Tensor& w = weights[l];
    detail::check_defined(w, "mlp", "weight");
    detail::check_same_dtype(x, w, "mlp");
    if (w.dim() != 2 || w.size(1) != s.widths.back())
      throw std::invalid_argument("mlp: weight " + std::to_string(l) + " " + to_string(w.shape()) +
                                  " does not fit [out, " + std::to_string(s.widths.back()) + "]");
    s.widths.push_back(w.size(0));
    if (!biases.empty()) {
      detail::check_defined(biases[l], "mlp", "bias");
      detail::check_same_dtype(x, biases[l], "mlp");
      if (biases[l].shape() != Shape{w.size(0)})
        throw std::invalid_argument("mlp: bias " + std::to_string(l) + " of shape " + to_string(biases[l].shape()) +
                                    " does not match weight " + to_string(w.shape()));
    }
    s.activations.push_back(l + 1 < weights.size() ? hidden : last);
  }
  s.rows = x.size(0);
  s.count = static_cast<std::int64_t>(weights.size());
  s.has_bias = !biases.empty();
  return s;
}

std::int64_t multiply_adds(const Layers& s) {
  std::int64_t work = 0;
  for (std::int64_t l = 0; l < s.count; ++l) work += s.rows * s.widths[l] * s.widths[l + 1];
  return work;
}

// The same gradients as ops (create_graph): the layers are run again as linear ops so their outputs are on the
// graph, then the chain rule is written with ops.
Grads recorded_gradients(const Layers& s, const Tensor& g, const Tensor& x, const std::vector<Tensor>& weights,
                         const std::vector<Tensor>& biases, const Needs& need) {
  std::vector<Tensor> outputs;
  Tensor h = x;
  for (std::size_t l = 0; l < weights.size(); ++l) {
    h = linear(h, weights[l], s.has_bias ? biases[l] : Tensor(), s.activations[l]);
    outputs.push_back(h);
  }
  const std::size_t per_layer = s.has_bias ? 2 : 1;
  Grads grads(1 + per_layer * weights.size());
  Tensor grad_out = g;
  for (std::int64_t l = s.count - 1; l >= 0; --l) {
    const std::size_t slot = 1 + per_layer * static_cast<std::size_t>(l), li = static_cast<std::size_t>(l);
    const Tensor gz = s.activations[li] == Fused::Tanh ? tanh_backward(grad_out, outputs[li]) : grad_out;
    if (s.has_bias && need[slot + 1]) grads[slot + 1] = sum(gz, {0});
    if (need[slot]) grads[slot] = gemm(gz, l > 0 ? outputs[li - 1] : x, true, false);
    if (l > 0 || need[0]) grad_out = matmul(gz, weights[li]);
  }
  if (need[0]) grads[0] = grad_out;
  return grads;
}

}  // namespace

namespace detail {

void linear_stack_forward(const LinearStack& s, const Tensor& x, const std::vector<Tensor>& weights,
                          const std::vector<Tensor>& biases, std::vector<Tensor> outputs) {
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    const std::int64_t units = (s.rows + 15) / 16;
    parallel_for(units, multiply_adds(s) < detail::kParallelGemmWork ? units : 1,
                 [&](std::int64_t u0, std::int64_t u1) {
                   for (std::int64_t r0 = u0 * 16, end = std::min(s.rows, u1 * 16); r0 < end; r0 += kRowBlock) {
                     const std::int64_t r1 = std::min(end, r0 + kRowBlock);
                     for (std::int64_t l = 0; l < s.count; ++l) {
                       const std::size_t li = static_cast<std::size_t>(l);
                       const std::int64_t in = s.widths[l], out = s.widths[l + 1];
                       const T* input = (l == 0 ? x.data<T>() : outputs[li - 1].data<T>()) + r0 * in;
                       affine_block<T>({input, r1 - r0, in, in}, {weights[li].data<T>(), out, in, in}, true,
                                       s.has_bias ? biases[li].data<T>() : nullptr, s.activations[li],
                                       outputs[li].data<T>() + r0 * out, r1 - r0, out);
                     }
                   }
                 });
  });
}

Grads linear_stack_gradients(const LinearStack& s, const Tensor& g, const Tensor& x, const std::vector<Tensor>& weights,
                             const std::vector<Tensor>& outputs, const Needs& need) {
  const std::size_t per_layer = s.has_bias ? 2 : 1;
  Grads grads(1 + per_layer * static_cast<std::size_t>(s.count));
  if (need[0]) grads[0] = empty({s.rows, s.widths[0]}, x.dtype());
  const std::int64_t widest = *std::max_element(s.widths.begin(), s.widths.end());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    using Matrix = RowMatrix<T>;
    const std::int64_t units = (s.rows + 15) / 16;
    const std::int64_t ranges =
        std::max<std::int64_t>(1, parallel_ranges(units, multiply_adds(s) < detail::kParallelGemmWork ? units : 1));
    // Per range and layer: the weight and bias sums (zero when there are no rows), added up in range order.
    std::vector<std::vector<Matrix>> weight_sums(static_cast<std::size_t>(ranges));
    std::vector<std::vector<Array>> bias_sums(static_cast<std::size_t>(ranges));
    for (std::size_t r = 0; r < weight_sums.size(); ++r)
      for (std::int64_t l = 0; l < s.count; ++l) {
        const std::size_t slot = 1 + per_layer * static_cast<std::size_t>(l);
        weight_sums[r].push_back(Matrix::Zero(need[slot] ? s.widths[l + 1] : 0, s.widths[l]));
        bias_sums[r].push_back(Array::Zero(s.has_bias && need[slot + 1] ? s.widths[l + 1] : 0));
      }
    parallel_for_ranges(units, ranges, [&](std::int64_t r, std::int64_t u0, std::int64_t u1) {
      const std::size_t range = static_cast<std::size_t>(r);
      Matrix upper(std::min(kRowBlock, s.rows), widest), lower(std::min(kRowBlock, s.rows), widest);
      Array block_sums(widest);
      for (std::int64_t r0 = u0 * 16, last = std::min(s.rows, u1 * 16); r0 < last; r0 += kRowBlock) {
        const std::int64_t r1 = std::min(last, r0 + kRowBlock), n = r1 - r0;
        const T* grad_out = g.data<T>() + r0 * s.widths.back();
        for (std::int64_t l = s.count - 1; l >= 0; --l) {
          const std::int64_t in = s.widths[l], out = s.widths[l + 1], count = n * out;
          const std::size_t slot = 1 + per_layer * static_cast<std::size_t>(l);
          // The gradient before the activation: computed into the scratch block (over grad_out when that is the
          // scratch block: the same index is read and written), or grad_out itself without an activation.
          const T* gz = grad_out;
          if (s.activations[static_cast<std::size_t>(l)] == Fused::Tanh) {
            const Eigen::Map<const Array> y(outputs[static_cast<std::size_t>(l)].data<T>() + r0 * out, count);
            Eigen::Map<Array>(upper.data(), count) = Eigen::Map<const Array>(grad_out, count) * (T(1) - y * y);
            gz = upper.data();
          }
          const MatrixRef<const T> gz_block{gz, n, out, out};
          if (s.has_bias && need[slot + 1]) {
            column_sums<T>(gz, n, out, block_sums.data());
            bias_sums[range][static_cast<std::size_t>(l)] += block_sums.head(out);
          }
          const T* input = (l == 0 ? x.data<T>() : outputs[static_cast<std::size_t>(l - 1)].data<T>()) + r0 * in;
          if (need[slot])
            detail::gemm_serial<T>(gz_block, true, {input, n, in, in}, false,
                                   {weight_sums[range][static_cast<std::size_t>(l)].data(), out, in, in}, true);
          if (l > 0 || grads[0].defined()) {
            T* below = l > 0 ? lower.data() : grads[0].data<T>() + r0 * in;
            detail::gemm_serial<T>(gz_block, false, {weights[static_cast<std::size_t>(l)].data<T>(), out, in, in},
                                   false, {below, n, in, in}, false);
            grad_out = below;
            std::swap(upper, lower);
          }
        }
      }
    });
    for (std::int64_t l = 0; l < s.count; ++l) {
      const std::size_t slot = 1 + per_layer * static_cast<std::size_t>(l), li = static_cast<std::size_t>(l);
      if (need[slot]) {
        grads[slot] = empty(weights[li].shape(), x.dtype());
        Eigen::Map<Matrix> total(grads[slot].data<T>(), s.widths[l + 1], s.widths[l]);
        total = weight_sums[0][li];
        for (std::size_t r = 1; r < weight_sums.size(); ++r) total += weight_sums[r][li];
      }
      if (s.has_bias && need[slot + 1]) {
        grads[slot + 1] = empty({s.widths[l + 1]}, x.dtype());
        Eigen::Map<Array> total(grads[slot + 1].data<T>(), s.widths[l + 1]);
        total = bias_sums[0][li];
        for (std::size_t r = 1; r < bias_sums.size(); ++r) total += bias_sums[r][li];
      }
    }
  });
  return grads;
}

}  // namespace detail

Tensor mlp(const Tensor& x, const std::vector<Tensor>& weights, const std::vector<Tensor>& biases, Fused hidden,
           Fused last) {
  const Layers s = check_layers(x, weights, biases, hidden, last);
  std::vector<Tensor> outputs;
  for (std::int64_t l = 0; l < s.count; ++l) outputs.push_back(empty({s.rows, s.widths[l + 1]}, x.dtype()));
  detail::linear_stack_forward(s, x, weights, biases, outputs);
  std::vector<Tensor> inputs{x};
  for (std::size_t l = 0; l < weights.size(); ++l) {
    inputs.push_back(weights[l]);
    if (s.has_bias) inputs.push_back(biases[l]);
  }
  std::vector<Tensor> hidden_outputs(outputs.begin(), outputs.end() - 1);
  return record(
      "mlp", outputs.back(), inputs,
      [s, x, weights, biases, hidden_outputs](const Tensor& g, const Needs& need, Node& self) {
        if (GradMode::is_enabled()) return recorded_gradients(s, g, x, weights, biases, need);
        std::vector<Tensor> all = hidden_outputs;
        all.push_back(self.output());
        return detail::linear_stack_gradients(s, g, x, weights, all, need);
      },
      true);
}

}  // namespace maps::ag
