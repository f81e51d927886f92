#include "autograd/tensor.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>
#include <sstream>
#include <stdexcept>

#include "autograd/engine.h"
#include "autograd/generator.h"
#include "autograd/grad_mode.h"
#include "autograd/node.h"
#include "autograd/ops.h"
#include "autograd/storage_pool.h"

namespace maps::ag {

namespace {
constexpr std::size_t kAlignment = 64;

std::shared_ptr<TensorImpl> make_impl(const Shape& shape, Dtype dtype) {
  for (std::int64_t d : shape) {
    if (d < 0) throw std::invalid_argument("tensor: negative size in shape " + to_string(shape));
  }
  auto impl = std::make_shared<TensorImpl>();
  impl->shape = shape;
  impl->dtype = dtype;
  impl->storage = std::make_shared<Storage>(static_cast<std::size_t>(numel_of(shape)) * element_size(dtype));
  return impl;
}
}  // namespace

namespace {
std::size_t block_bytes(std::size_t bytes) {
  const std::size_t rounded = (bytes + kAlignment - 1) / kAlignment * kAlignment;
  return rounded == 0 ? kAlignment : rounded;
}
}  // namespace

Storage::Storage(std::size_t bytes) : data_(detail::pool_allocate(block_bytes(bytes))), bytes_(bytes) {}

Storage::~Storage() { detail::pool_release(data_, block_bytes(bytes_)); }

void Tensor::check_defined(const char* what) const {
  if (!impl_) throw std::logic_error(std::string(what) + ": the tensor is undefined");
}

const Shape& Tensor::shape() const {
  check_defined("shape");
  return impl_->shape;
}

std::int64_t Tensor::size(std::int64_t d) const { return shape()[normalize_dim(d, dim(), "size")]; }

std::int64_t Tensor::numel() const { return numel_of(shape()); }

Dtype Tensor::dtype() const {
  check_defined("dtype");
  return impl_->dtype;
}

template <typename T>
T* Tensor::data() {
  check_defined("data");
  if (impl_->dtype != dtype_of<T>()) {
    throw std::invalid_argument("data: the tensor is " + ag::to_string(impl_->dtype) + ", not " +
                                ag::to_string(dtype_of<T>()));
  }
  return static_cast<T*>(impl_->storage->data());
}

template <typename T>
const T* Tensor::data() const {
  return const_cast<Tensor*>(this)->data<T>();
}

template float* Tensor::data<float>();
template double* Tensor::data<double>();
template const float* Tensor::data<float>() const;
template const double* Tensor::data<double>() const;

double Tensor::at(std::int64_t flat_index) const {
  if (flat_index < 0 || flat_index >= numel()) {
    throw std::out_of_range("at: index " + std::to_string(flat_index) + " is outside a tensor of shape " +
                            ag::to_string(shape()));
  }
  return dispatch_dtype(dtype(), [&](auto tag) -> double {
    using T = typename decltype(tag)::type;
    return static_cast<double>(data<T>()[flat_index]);
  });
}

double Tensor::item() const {
  if (numel() != 1) {
    throw std::invalid_argument("item: the tensor has shape " + ag::to_string(shape()) + ", not one element");
  }
  return at(0);
}

std::vector<double> Tensor::to_vector() const {
  std::vector<double> out(static_cast<std::size_t>(numel()));
  dispatch_dtype(dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    const T* p = data<T>();
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<double>(p[i]);
  });
  return out;
}

namespace {
std::pair<std::int64_t, std::int64_t> matrix_dims(const Tensor& t) {
  if (t.dim() == 2) return {t.shape()[0], t.shape()[1]};
  if (t.dim() == 1) return {1, t.shape()[0]};
  if (t.dim() == 0) return {1, 1};
  throw std::invalid_argument("matrix: a tensor of shape " + to_string(t.shape()) + " is not 1-d or 2-d");
}
}  // namespace

template <typename T>
Eigen::Map<RowMatrix<T>> Tensor::matrix() {
  auto [r, c] = matrix_dims(*this);
  return {data<T>(), r, c};
}

template <typename T>
Eigen::Map<const RowMatrix<T>> Tensor::matrix() const {
  auto [r, c] = matrix_dims(*this);
  return {data<T>(), r, c};
}

template <typename T>
Eigen::Map<Eigen::Array<T, Eigen::Dynamic, 1>> Tensor::array() {
  return {data<T>(), numel()};
}

template <typename T>
Eigen::Map<const Eigen::Array<T, Eigen::Dynamic, 1>> Tensor::array() const {
  return {data<T>(), numel()};
}

template Eigen::Map<RowMatrixF> Tensor::matrix<float>();
template Eigen::Map<RowMatrixD> Tensor::matrix<double>();
template Eigen::Map<const RowMatrixF> Tensor::matrix<float>() const;
template Eigen::Map<const RowMatrixD> Tensor::matrix<double>() const;
template Eigen::Map<Eigen::ArrayXf> Tensor::array<float>();
template Eigen::Map<Eigen::ArrayXd> Tensor::array<double>();
template Eigen::Map<const Eigen::ArrayXf> Tensor::array<float>() const;
template Eigen::Map<const Eigen::ArrayXd> Tensor::array<double>() const;

bool Tensor::requires_grad() const {
  check_defined("requires_grad");
  return impl_->requires_grad;
}

Tensor& Tensor::requires_grad_(bool on) {
  check_defined("requires_grad_");
  if (impl_->grad_fn) {
    throw std::logic_error("requires_grad_: only a leaf can be marked; this tensor was made by " +
                           impl_->grad_fn->op() + " (use detach() first)");
  }
  impl_->requires_grad = on;
  return *this;
}

bool Tensor::is_leaf() const {
  check_defined("is_leaf");
  return impl_->grad_fn == nullptr;
}

Tensor Tensor::grad() const {
  check_defined("grad");
  return Tensor(impl_->grad);
}

void Tensor::set_grad(const Tensor& grad) {
  check_defined("set_grad");
  if (grad.defined() && (grad.shape() != shape() || grad.dtype() != dtype())) {
    throw std::invalid_argument("set_grad: a gradient of shape " + ag::to_string(grad.shape()) + " " +
                                ag::to_string(grad.dtype()) + " does not fit a tensor of shape " +
                                ag::to_string(shape()) + " " + ag::to_string(dtype()));
  }
  impl_->grad = grad.impl();
}

const std::shared_ptr<Node>& Tensor::grad_fn() const {
  check_defined("grad_fn");
  return impl_->grad_fn;
}

Tensor Tensor::detach() const {
  check_defined("detach");
  auto impl = std::make_shared<TensorImpl>();
  impl->shape = impl_->shape;
  impl->dtype = impl_->dtype;
  impl->storage = impl_->storage;
  return Tensor(impl);
}

Tensor Tensor::clone() const {
  check_defined("clone");
  Tensor out(make_impl(shape(), dtype()));
  std::memcpy(out.impl()->storage->data(), impl_->storage->data(), impl_->storage->bytes());
  return record(
      "clone", out, {*this}, [](const Tensor& g, const std::vector<bool>&, Node&) { return std::vector<Tensor>{g}; },
      false, Reads::none());
}

Tensor Tensor::to(Dtype target) const {
  check_defined("to");
  if (target == dtype()) return *this;
  Tensor out(make_impl(shape(), target));
  dispatch_dtype(dtype(), [&](auto from) {
    using S = typename decltype(from)::type;
    dispatch_dtype(target, [&](auto to) {
      using D = typename decltype(to)::type;
      out.array<D>() = array<S>().template cast<D>();
    });
  });
  const Dtype source = dtype();
  return record(
      "to", out, {*this},
      [source](const Tensor& g, const std::vector<bool>&, Node&) { return std::vector<Tensor>{g.to(source)}; }, false,
      Reads::none());
}

void Tensor::backward(const Tensor& gradient, bool retain_graph, bool create_graph) const {
  ag::backward({*this}, gradient.defined() ? std::vector<Tensor>{gradient} : std::vector<Tensor>{}, retain_graph,
               create_graph);
}

void Tensor::copy_(const Tensor& source) {
  check_defined("copy_");
  if (source.shape() != shape() || source.dtype() != dtype()) {
    throw std::invalid_argument("copy_: source of shape " + ag::to_string(source.shape()) + " " +
                                ag::to_string(source.dtype()) + " does not match destination " +
                                ag::to_string(shape()) + " " + ag::to_string(dtype()));
  }
  if (source.impl()->storage != impl_->storage) {
    std::memcpy(impl_->storage->data(), source.impl()->storage->data(), impl_->storage->bytes());
  }
  impl_->storage->bump_version();
}

void Tensor::bump_version() {
  check_defined("bump_version");
  impl_->storage->bump_version();
}

std::uint64_t Tensor::version() const {
  check_defined("version");
  return impl_->storage->version();
}

void Tensor::fill_(double value) {
  check_defined("fill_");
  dispatch_dtype(dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    array<T>().setConstant(static_cast<T>(value));
  });
  impl_->storage->bump_version();
}

Tensor Tensor::reshape(const Shape& new_shape) const { return ag::reshape(*this, new_shape); }

Tensor Tensor::transpose(std::int64_t dim0, std::int64_t dim1) const { return ag::transpose(*this, dim0, dim1); }

std::string Tensor::to_string() const {
  if (!impl_) return "Tensor(undefined)";
  std::ostringstream out;
  out << "Tensor(shape=" << ag::to_string(shape()) << ", dtype=" << ag::to_string(dtype());
  if (requires_grad()) out << ", requires_grad";
  out << ", values=[";
  const std::int64_t n = numel();
  const std::int64_t shown = std::min<std::int64_t>(n, 64);
  for (std::int64_t i = 0; i < shown; ++i) out << (i ? ", " : "") << at(i);
  if (shown < n) out << ", ... (" << n << " in all)";
  out << "])";
  return out.str();
}

std::string shape_text(const Tensor& t) { return t.defined() ? to_string(t.shape()) : "an undefined tensor"; }

// ----- factories -----

Tensor empty(const Shape& shape, Dtype dtype) { return Tensor(make_impl(shape, dtype)); }

Tensor full(const Shape& shape, double value, Dtype dtype) {
  Tensor t = empty(shape, dtype);
  t.fill_(value);
  return t;
}

Tensor zeros(const Shape& shape, Dtype dtype) { return full(shape, 0.0, dtype); }
Tensor ones(const Shape& shape, Dtype dtype) { return full(shape, 1.0, dtype); }
Tensor scalar_tensor(double value, Dtype dtype) { return full({}, value, dtype); }
Tensor zeros_like(const Tensor& t) { return zeros(t.shape(), t.dtype()); }
Tensor ones_like(const Tensor& t) { return ones(t.shape(), t.dtype()); }
Tensor full_like(const Tensor& t, double value) { return full(t.shape(), value, t.dtype()); }

Tensor arange(double start, double end, double step, Dtype dtype) {
  if (!std::isfinite(start) || !std::isfinite(end) || !std::isfinite(step)) {
    throw std::invalid_argument("arange: start, end and step must be finite");
  }
  if (step == 0.0) throw std::invalid_argument("arange: step must not be 0");
  const double count = std::ceil((end - start) / step);
  const auto n = static_cast<std::int64_t>(std::max(0.0, count));
  Tensor t = empty({n}, dtype);
  dispatch_dtype(dtype, [&](auto tag) {
    using T = typename decltype(tag)::type;
    T* p = t.data<T>();
    for (std::int64_t i = 0; i < n; ++i) p[i] = static_cast<T>(start + static_cast<double>(i) * step);
  });
  return t;
}

Tensor rand(const Shape& shape, Generator& gen, Dtype dtype, double low, double high) {
  if (!(low < high)) {
    throw std::invalid_argument("rand: low (" + std::to_string(low) + ") must be below high (" + std::to_string(high) +
                                ")");
  }
  Tensor t = empty(shape, dtype);
  dispatch_dtype(dtype, [&](auto tag) {
    using T = typename decltype(tag)::type;
    T* p = t.data<T>();
    for (std::int64_t i = 0; i < t.numel(); ++i) p[i] = static_cast<T>(gen.uniform(low, high));
  });
  return t;
}

Tensor randn(const Shape& shape, Generator& gen, Dtype dtype) {
  Tensor t = empty(shape, dtype);
  dispatch_dtype(dtype, [&](auto tag) {
    using T = typename decltype(tag)::type;
    T* p = t.data<T>();
    for (std::int64_t i = 0; i < t.numel(); ++i) p[i] = static_cast<T>(gen.normal());
  });
  return t;
}

namespace {
void check_fills(std::size_t count, const Shape& shape) {
  if (static_cast<std::int64_t>(count) != numel_of(shape)) {
    throw std::invalid_argument("from_vector: " + std::to_string(count) + " values do not fill shape " +
                                to_string(shape) + " (" + std::to_string(numel_of(shape)) + " elements)");
  }
}
}  // namespace

Tensor from_vector(const std::vector<double>& values, const Shape& shape, Dtype dtype) {
  check_fills(values.size(), shape);
  Tensor t = empty(shape, dtype);
  dispatch_dtype(dtype, [&](auto tag) {
    using T = typename decltype(tag)::type;
    T* p = t.data<T>();
    for (std::size_t i = 0; i < values.size(); ++i) p[i] = static_cast<T>(values[i]);
  });
  return t;
}

Tensor from_vector(const std::vector<float>& values, const Shape& shape) {
  check_fills(values.size(), shape);
  Tensor t = empty(shape, Dtype::Float32);
  std::memcpy(t.data<float>(), values.data(), values.size() * sizeof(float));
  return t;
}

RowMatrixF to_eigen_float(const Tensor& t) {
  NoGradGuard no_grad;
  return t.to(Dtype::Float32).matrix<float>();
}

RowMatrixD to_eigen_double(const Tensor& t) {
  NoGradGuard no_grad;
  return t.to(Dtype::Float64).matrix<double>();
}

}  // namespace maps::ag
