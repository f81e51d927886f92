#include "nn/init.h"

#include <Eigen/QR>
#include <cmath>
#include <stdexcept>

namespace maps::nn::init {

namespace {

void check_defined(const ag::Tensor& tensor, const char* what) {
  if (!tensor.defined()) throw std::invalid_argument(std::string("init::") + what + ": tensor is undefined");
}

// Writes fn() into every element, in row-major order.
template <typename Fn>
void fill_with(ag::Tensor& tensor, Fn&& fn) {
  ag::NoGradGuard no_grad;
  tensor.bump_version();
  ag::dispatch_dtype(tensor.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    T* data = tensor.data<T>();
    const std::int64_t n = tensor.numel();
    for (std::int64_t i = 0; i < n; ++i) data[i] = static_cast<T>(fn());
  });
}

}  // namespace

std::pair<std::int64_t, std::int64_t> fan_in_and_fan_out(const ag::Tensor& tensor) {
  check_defined(tensor, "fan_in_and_fan_out");
  if (tensor.dim() < 2)
    throw std::invalid_argument("init::fan_in_and_fan_out: needs a tensor with at least 2 dims, got shape " +
                                ag::to_string(tensor.shape()));
  std::int64_t receptive = 1;
  for (std::int64_t d = 2; d < tensor.dim(); ++d) receptive *= tensor.size(d);
  return {tensor.size(1) * receptive, tensor.size(0) * receptive};
}

double calculate_gain(const std::string& nonlinearity, double param) {
  if (nonlinearity == "linear" || nonlinearity == "sigmoid" || nonlinearity == "identity") return 1.0;
  if (nonlinearity == "tanh") return 5.0 / 3.0;
  if (nonlinearity == "relu") return std::sqrt(2.0);
  if (nonlinearity == "leaky_relu") return std::sqrt(2.0 / (1.0 + param * param));
  throw std::invalid_argument("init::calculate_gain: unknown nonlinearity \"" + nonlinearity +
                              "\" (known: linear, identity, sigmoid, tanh, relu, leaky_relu)");
}

ag::Tensor& uniform_(ag::Tensor& tensor, double low, double high, ag::Generator& gen) {
  check_defined(tensor, "uniform_");
  if (!(low <= high))
    throw std::invalid_argument("init::uniform_: low (" + std::to_string(low) + ") must not exceed high (" +
                                std::to_string(high) + ")");
  fill_with(tensor, [&] { return gen.uniform(low, high); });
  return tensor;
}

ag::Tensor& normal_(ag::Tensor& tensor, double mean, double std, ag::Generator& gen) {
  check_defined(tensor, "normal_");
  if (!(std >= 0.0)) throw std::invalid_argument("init::normal_: std must be >= 0, got " + std::to_string(std));
  fill_with(tensor, [&] { return mean + std * gen.normal(); });
  return tensor;
}

ag::Tensor& constant_(ag::Tensor& tensor, double value) {
  check_defined(tensor, "constant_");
  ag::NoGradGuard no_grad;
  tensor.fill_(value);
  return tensor;
}

ag::Tensor& zeros_(ag::Tensor& tensor) { return constant_(tensor, 0.0); }

ag::Tensor& ones_(ag::Tensor& tensor) { return constant_(tensor, 1.0); }

ag::Tensor& kaiming_uniform_(ag::Tensor& tensor, ag::Generator& gen, double a, FanMode mode) {
  auto [fan_in, fan_out] = fan_in_and_fan_out(tensor);
  const double fan = static_cast<double>(mode == FanMode::FanIn ? fan_in : fan_out);
  if (fan <= 0)
    throw std::invalid_argument("init::kaiming_uniform_: zero fan for shape " + ag::to_string(tensor.shape()));
  const double bound = calculate_gain("leaky_relu", a) * std::sqrt(3.0 / fan);
  return uniform_(tensor, -bound, bound, gen);
}

ag::Tensor& xavier_uniform_(ag::Tensor& tensor, ag::Generator& gen, double gain) {
  auto [fan_in, fan_out] = fan_in_and_fan_out(tensor);
  if (fan_in + fan_out <= 0)
    throw std::invalid_argument("init::xavier_uniform_: zero fan for shape " + ag::to_string(tensor.shape()));
  const double bound = gain * std::sqrt(6.0 / static_cast<double>(fan_in + fan_out));
  return uniform_(tensor, -bound, bound, gen);
}

ag::Tensor& orthogonal_(ag::Tensor& tensor, double gain, ag::Generator& gen) {
  check_defined(tensor, "orthogonal_");
  if (tensor.dim() < 2)
    throw std::invalid_argument("init::orthogonal_: needs a tensor with at least 2 dims, got shape " +
                                ag::to_string(tensor.shape()));
  const std::int64_t rows = tensor.size(0);
  const std::int64_t cols = rows == 0 ? 0 : tensor.numel() / rows;
  if (rows == 0 || cols == 0) return tensor;
  // Draw [rows, cols] row-major like torch's new(rows, cols).normal_(), then work on the tall orientation.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> flat(rows, cols);
  for (std::int64_t i = 0; i < rows; ++i)
    for (std::int64_t j = 0; j < cols; ++j) flat(i, j) = gen.normal();
  const bool wide = rows < cols;
  Eigen::MatrixXd a = wide ? Eigen::MatrixXd(flat.transpose()) : Eigen::MatrixXd(flat);
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(a);
  Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(a.rows(), a.cols());
  const Eigen::VectorXd diag = qr.matrixQR().diagonal();
  for (Eigen::Index j = 0; j < q.cols(); ++j)
    if (diag(j) < 0) q.col(j) *= -1.0;  // sign(0) = 0 in torch; a zero diagonal has probability 0
  if (wide) q.transposeInPlace();
  q *= gain;
  ag::NoGradGuard no_grad;
  tensor.bump_version();
  ag::dispatch_dtype(tensor.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    T* data = tensor.data<T>();
    for (std::int64_t i = 0; i < rows; ++i)
      for (std::int64_t j = 0; j < cols; ++j) data[i * cols + j] = static_cast<T>(q(i, j));
  });
  return tensor;
}

}  // namespace maps::nn::init
