#pragma once

#include <cstdint>
#include <vector>

#include "autograd/tensor.h"

// Every op records its backward rule (written in these same ops) when grad mode is on and an
// input requires grad. Binary ops broadcast like NumPy; a shape or dtype mismatch throws an
// error naming the op and both shapes. Dims may be negative (counted from the end).
namespace maps::ag {

// ----- elementwise binary (broadcasting) -----
Tensor add(const Tensor& a, const Tensor& b);
Tensor sub(const Tensor& a, const Tensor& b);
Tensor mul(const Tensor& a, const Tensor& b);
Tensor div(const Tensor& a, const Tensor& b);
Tensor minimum(const Tensor& a, const Tensor& b);  // ties split the gradient evenly, like PyTorch
Tensor maximum(const Tensor& a, const Tensor& b);
Tensor pow(const Tensor& base, const Tensor& exponent);  // tensor exponent

// ----- with a scalar -----
Tensor add(const Tensor& a, double b);
Tensor mul(const Tensor& a, double b);
Tensor pow(const Tensor& base, double exponent);
Tensor rsub(double a, const Tensor& b);  // a - b
Tensor rdiv(double a, const Tensor& b);  // a / b

// ----- elementwise unary -----
Tensor neg(const Tensor& x);
Tensor exp(const Tensor& x);
Tensor log(const Tensor& x);
Tensor sqrt(const Tensor& x);
Tensor abs(const Tensor& x);                            // gradient sign(x), 0 at 0 like PyTorch
Tensor clamp(const Tensor& x, double min, double max);  // gradient passes where min <= x <= max
Tensor clamp_min(const Tensor& x, double min);
Tensor clamp_max(const Tensor& x, double max);
Tensor relu(const Tensor& x);
Tensor tanh(const Tensor& x);
// grad * (1 - output^2): tanh's backward as one pass over memory (output = tanh(x)); differentiable in both.
Tensor tanh_backward(const Tensor& grad, const Tensor& output);
Tensor sigmoid(const Tensor& x);
Tensor square(const Tensor& x);
Tensor softplus(const Tensor& x);  // log(1 + exp(x)), computed stably; gradient sigmoid(x), also at 0
Tensor erf(const Tensor& x);       // gradient 2/sqrt(pi) exp(-x^2); the normal CDF is 0.5 (1 + erf(x / sqrt(2)))
// Mish (Misra, 2019; Diffusion Policy's activation): x tanh(softplus(x)), one pass.
Tensor mish(const Tensor& x);
// grad * mish'(x): mish's backward as one pass over memory (composed of ops it took a tenth of a U-Net step);
// differentiable in both, its second derivative written in ops.
Tensor mish_backward(const Tensor& grad, const Tensor& x);

// ----- linear algebra -----
// [n,k]@[k,m] -> [n,m]; [b,n,k]@[b,k,m] -> [b,n,m]; [b,n,k]@[k,m] -> [b,n,m].
Tensor matmul(const Tensor& a, const Tensor& b);
// op(a) @ op(b), where op transposes the last two dims when asked; same ranks as matmul (a 3-d
// left operand against a 2-d right one cannot be transposed). No transposed copy is made.
Tensor gemm(const Tensor& a, const Tensor& b, bool transpose_a, bool transpose_b);
// Which kernel runs float32 products: "maps AVX-512" or "maps AVX2" (autograd/gemm_f32.h: the widest this build
// has and this CPU runs, chosen at run time, or MAPS_F32_KERNEL's), or "Eigen" (neither). float64 products always
// run Eigen's.
const char* float32_gemm_kernel();
// Counts the FLOPs (2 m n k per product) of every matrix product any thread runs while it lives, in every op that
// multiplies (matmul, gemm, linear, parallel_linear, mlp, parallel_mlp, and their gradients): `maps bench step`'s
// work count for any method's step. Counters may nest; each sees the products since it was made.
class GemmFlopCounter {
 public:
  GemmFlopCounter();
  ~GemmFlopCounter();
  GemmFlopCounter(const GemmFlopCounter&) = delete;
  GemmFlopCounter& operator=(const GemmFlopCounter&) = delete;
  double flops() const;

 private:
  std::uint64_t start_;
};
// Classical Gram-Schmidt per sample (ops_orthogonal.cpp): v [k, n, F] holds k vectors of width F for each of n
// samples; u_i = normalise(v_i - sum_{j<i} <v_i, u_j> u_j) in the order of k -> [k, n, F], orthonormal per sample
// (MOORE's orthogonal layer). Needs k <= F; no epsilon in the division, like MOORE's: linearly dependent vectors
// give non-finite values. Gradients are ops again (create_graph): the thin QR's rule V = R^T U, solved with R.
Tensor gram_schmidt(const Tensor& v);

// ----- layers (ops_layer.cpp) -----
// An activation a layer op applies in its own pass over its output, while the output is still in cache.
enum class Fused { None, Tanh };
// act(x @ weight^T + bias), like torch::nn::functional::linear: x [..., in], weight [out, in], bias [out] or
// undefined. The output starts as the bias and the GEMM adds to it; the activation runs in place.
Tensor linear(const Tensor& x, const Tensor& weight, const Tensor& bias = Tensor(), Fused activation = Fused::None);
// M independent layers act(x_m @ weight_m + bias_m): x [M, B, in] (one input per layer) or [B, in] (the same input
// for every layer), weight [M, in, out], bias [M, 1, out] or undefined -> [M, B, out]. The threads share out the
// layers. Gradients are ops again (create_graph works).
Tensor parallel_linear(const Tensor& x, const Tensor& weight, const Tensor& bias = Tensor(),
                       Fused activation = Fused::None);
// A stack of parallel_linear layers with `activation` after every one: x [M, B, in] or [B, in] (shared), weights[l]
// [M, in_l, out_l] (out_l = in_{l+1}), biases one [M, 1, out_l] per layer or none. Runs member by member, each
// member's whole stack while its activations are in cache (and so its gradients); the threads share out the
// members. Gradients are ops again when recorded (create_graph).
Tensor parallel_mlp(const Tensor& x, const std::vector<Tensor>& weights, const std::vector<Tensor>& biases,
                    Fused activation);
// A stack of linear layers: x [rows, in], weights[l] [out_l, in_l] (in_{l+1} = out_l), biases one [out_l] per layer
// or none; `hidden` after every layer but the last, `last` after the last. Runs in blocks of rows, each block
// through every layer while its activations are in cache (and so its gradients); the threads share out the blocks.
// Gradients are ops again when recorded (create_graph).
Tensor mlp(const Tensor& x, const std::vector<Tensor>& weights, const std::vector<Tensor>& biases, Fused hidden,
           Fused last = Fused::None);
// act(a[a_rows[i]] + b[b_rows[i]]) for each i: rows of two 2-d tables with the same row length, summed, with the
// activation in the same pass -> [a_rows.size(), width] (MAPS's selector first layer: a state's part plus its
// task's row, for every state under every task). Gradients scatter back with index_add.
Tensor gather_add(const Tensor& a, const std::vector<std::int64_t>& a_rows, const Tensor& b,
                  const std::vector<std::int64_t>& b_rows, Fused activation = Fused::None);

// ----- 1-D convolution (ops_conv.cpp) -----
// torch.nn.functional.conv1d with stride 1: x [batch, in, length], weight [out, in, kernel], bias [out] or undefined,
// `padding` zeros at both ends -> [batch, out, length + 2 padding - kernel + 1]; out[b, o, t] = bias[o] +
// sum_{c, k} weight[o, c, k] x[b, c, t + k - padding]. One GEMM over every window of the batch.
Tensor conv1d(const Tensor& x, const Tensor& weight, const Tensor& bias, std::int64_t padding);
// Its adjoints, ops in their own right so that each rule is written in the others (second order): the gradient at x
// of conv1d's output gradient [batch, out, out_length] for an input of `length` -> [batch, in, length], and the
// gradient at the weight, summed over the batch -> [out, in, kernel].
Tensor conv1d_input_grad(const Tensor& grad_output, const Tensor& weight, std::int64_t length, std::int64_t padding);
Tensor conv1d_weight_grad(const Tensor& x, const Tensor& grad_output, std::int64_t kernel, std::int64_t padding);

// ----- normalisation (ops_norm.cpp) -----
// torch.nn.functional.group_norm without the affine part: x [batch, channels, ...] with channels split into `groups`
// contiguous groups, each (row, group) standardised over its channels and positions, variance biased, eps inside the
// square root. One pass forward and one back; under create_graph the rule is ops (second order).
Tensor group_norm(const Tensor& x, std::int64_t groups, double eps = 1e-5);

// ----- shape -----
Tensor reshape(const Tensor& x, const Shape& shape);  // one dim may be -1
Tensor transpose(const Tensor& x, std::int64_t dim0, std::int64_t dim1);
Tensor expand(const Tensor& x, const Shape& shape);  // broadcast to shape (copying)
// Sums a broadcast gradient back down to `shape` (the reverse of expand).
Tensor sum_to(const Tensor& x, const Shape& shape);
Tensor concat(const std::vector<Tensor>& tensors, std::int64_t dim);
Tensor stack(const std::vector<Tensor>& tensors, std::int64_t dim);
Tensor narrow(const Tensor& x, std::int64_t dim, std::int64_t start, std::int64_t length);
inline Tensor slice(const Tensor& x, std::int64_t dim, std::int64_t start, std::int64_t end) {
  return narrow(x, dim, start, end - start);
}
// Rows (dim 0) picked by index; indices are checked against x.size(0).
Tensor index_select(const Tensor& x, const std::vector<std::int64_t>& indices);
// The adjoint of index_select: a [rows, ...] tensor of zeros with each source row added at its index.
Tensor index_add(const Tensor& source, const std::vector<std::int64_t>& indices, std::int64_t rows);

// ----- reductions -----
Tensor sum(const Tensor& x);  // shape {}
Tensor sum(const Tensor& x, const std::vector<std::int64_t>& dims, bool keepdim = false);
Tensor mean(const Tensor& x);
Tensor mean(const Tensor& x, const std::vector<std::int64_t>& dims, bool keepdim = false);
// Largest value; ties share the gradient evenly, like torch.amax.
Tensor amax(const Tensor& x);
Tensor amax(const Tensor& x, const std::vector<std::int64_t>& dims, bool keepdim = false);

// ----- softmax family -----
Tensor softmax(const Tensor& x, std::int64_t dim);
Tensor log_softmax(const Tensor& x, std::int64_t dim);

// ----- losses and encodings -----
Tensor mse_loss(const Tensor& prediction, const Tensor& target);  // mean of squared differences
// [n] indices -> [n, classes] of 0/1; indices must lie in [0, classes). Records no graph.
Tensor one_hot(const std::vector<std::int64_t>& indices, std::int64_t classes, Dtype dtype = Dtype::Float32);

// condition ? a : b elementwise; condition (any nonzero is true), a and b must share one shape.
// Differentiable in a and b; the unselected side gets a zero gradient (not NaN * 0).
Tensor where(const Tensor& condition, const Tensor& a, const Tensor& b);

// ----- comparisons (record no graph; 1 where true, 0 elsewhere) -----
Tensor gt(const Tensor& a, const Tensor& b);
Tensor eq(const Tensor& a, const Tensor& b);

// ----- operators -----
inline Tensor operator+(const Tensor& a, const Tensor& b) { return add(a, b); }
inline Tensor operator-(const Tensor& a, const Tensor& b) { return sub(a, b); }
inline Tensor operator*(const Tensor& a, const Tensor& b) { return mul(a, b); }
inline Tensor operator/(const Tensor& a, const Tensor& b) { return div(a, b); }
inline Tensor operator-(const Tensor& a) { return neg(a); }
inline Tensor operator+(const Tensor& a, double b) { return add(a, b); }
inline Tensor operator+(double a, const Tensor& b) { return add(b, a); }
inline Tensor operator-(const Tensor& a, double b) { return add(a, -b); }
inline Tensor operator-(double a, const Tensor& b) { return rsub(a, b); }
inline Tensor operator*(const Tensor& a, double b) { return mul(a, b); }
inline Tensor operator*(double a, const Tensor& b) { return mul(b, a); }
inline Tensor operator/(const Tensor& a, double b) { return mul(a, 1.0 / b); }
inline Tensor operator/(double a, const Tensor& b) { return rdiv(a, b); }

}  // namespace maps::ag
