#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "autograd/dtype.h"
#include "autograd/shape.h"

namespace maps::ag {

class Node;
class Generator;

// Contiguous, 64-byte aligned bytes shared by a tensor and its reshaped or detached views.
class Storage {
 public:
  Storage(std::size_t bytes);
  ~Storage();
  Storage(const Storage&) = delete;
  Storage& operator=(const Storage&) = delete;
  void* data() const { return data_; }
  std::size_t bytes() const { return bytes_; }
  // Counts in-place changes (copy_, fill_, optimiser steps, ...). A node notes the versions of what its backward
  // rule will read and refuses to run if one moved, as PyTorch does, instead of using the changed values.
  std::uint64_t version() const { return version_; }
  void bump_version() { ++version_; }

 private:
  void* data_;
  std::size_t bytes_;
  std::uint64_t version_ = 0;
};

struct TensorImpl {
  Shape shape;
  Dtype dtype = Dtype::Float32;
  std::shared_ptr<Storage> storage;
  bool requires_grad = false;
  std::shared_ptr<Node> grad_fn;     // null for leaves and for tensors made without grad
  std::shared_ptr<TensorImpl> grad;  // accumulated by backward() on leaves
};

// Tensors are row-major, so their Eigen views are too.
template <typename T>
using RowMatrix = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatrixF = RowMatrix<float>;
using RowMatrixD = RowMatrix<double>;

// A cheap handle with shared ownership, like torch::Tensor: copying a Tensor aliases it.
// Storage is always contiguous and row-major. A default-constructed Tensor is "undefined".
class Tensor {
 public:
  Tensor() = default;
  explicit Tensor(std::shared_ptr<TensorImpl> impl) : impl_(std::move(impl)) {}

  bool defined() const { return impl_ != nullptr; }
  const Shape& shape() const;
  std::int64_t dim() const { return static_cast<std::int64_t>(shape().size()); }
  std::int64_t size(std::int64_t dim) const;  // negative dims count from the end
  std::int64_t numel() const;
  Dtype dtype() const;

  // Typed access to the storage; throws when T does not match dtype().
  template <typename T>
  T* data();
  template <typename T>
  const T* data() const;
  // The value of a one-element tensor, as double.
  double item() const;
  // The element at a flat row-major index, as double (for tests and reports, not hot loops).
  double at(std::int64_t flat_index) const;
  std::vector<double> to_vector() const;

  // Eigen views of a 1-d or 2-d tensor ([n] is seen as a 1 x n row); no copy.
  template <typename T>
  Eigen::Map<RowMatrix<T>> matrix();
  template <typename T>
  Eigen::Map<const RowMatrix<T>> matrix() const;
  // Flat array view of every element; no copy.
  template <typename T>
  Eigen::Map<Eigen::Array<T, Eigen::Dynamic, 1>> array();
  template <typename T>
  Eigen::Map<const Eigen::Array<T, Eigen::Dynamic, 1>> array() const;

  // Autograd state.
  bool requires_grad() const;
  // Marks a leaf as one whose gradient backward() accumulates; throws on a non-leaf.
  Tensor& requires_grad_(bool on = true);
  bool is_leaf() const;
  // The accumulated gradient of a leaf (undefined until a backward pass reaches it).
  Tensor grad() const;
  void set_grad(const Tensor& grad);
  const std::shared_ptr<Node>& grad_fn() const;
  // Same storage, cut from the graph.
  Tensor detach() const;
  // A new storage holding a copy of the values (recorded on the graph: its gradient is the identity).
  Tensor clone() const;
  // Converts to another dtype (recorded on the graph); returns *this when the dtype already matches.
  Tensor to(Dtype dtype) const;
  // Accumulates the gradients of this scalar (or of `gradient`'s vector-Jacobian product) into leaves.
  void backward(const Tensor& gradient = Tensor(), bool retain_graph = false, bool create_graph = false) const;

  // Copies values from `source` (same shape and dtype) into this tensor's storage, recording nothing.
  // For optimisers and loading. Both count as an in-place change: a backward pass that needs the old values then
  // fails naming the op, instead of using the new ones.
  void copy_(const Tensor& source);
  void fill_(double value);
  // Code that changes values through data(), matrix() or array() after creation calls this, so that graphs that
  // saved this storage notice (every tensor sharing the storage shares the count).
  void bump_version();
  std::uint64_t version() const;

  // Shape ops (graph-recorded; see ops.h for the rest).
  Tensor reshape(const Shape& shape) const;
  Tensor transpose(std::int64_t dim0, std::int64_t dim1) const;
  Tensor t() const { return transpose(0, 1); }  // 2-d transpose

  const std::shared_ptr<TensorImpl>& impl() const { return impl_; }
  std::string to_string() const;  // shape, dtype and the values (abbreviated past 64 elements)

 private:
  void check_defined(const char* what) const;
  std::shared_ptr<TensorImpl> impl_;
};

// Factories. Every factory takes the dtype last, defaulting to float32.
Tensor empty(const Shape& shape,
             Dtype dtype = Dtype::Float32);  // uninitialised: only for kernels that write every element
Tensor zeros(const Shape& shape, Dtype dtype = Dtype::Float32);
Tensor ones(const Shape& shape, Dtype dtype = Dtype::Float32);
Tensor full(const Shape& shape, double value, Dtype dtype = Dtype::Float32);
Tensor scalar_tensor(double value, Dtype dtype = Dtype::Float32);  // shape {}
Tensor zeros_like(const Tensor& t);
Tensor ones_like(const Tensor& t);
Tensor full_like(const Tensor& t, double value);
// 0, step, 2*step, ... below end (like torch.arange(start, end, step)).
Tensor arange(double start, double end, double step = 1.0, Dtype dtype = Dtype::Float32);
// Uniform in [low, high) and standard normal, from a seeded generator.
Tensor rand(const Shape& shape, Generator& gen, Dtype dtype = Dtype::Float32, double low = 0.0, double high = 1.0);
Tensor randn(const Shape& shape, Generator& gen, Dtype dtype = Dtype::Float32);
// From values in row-major order; throws when values.size() does not match the shape.
Tensor from_vector(const std::vector<double>& values, const Shape& shape, Dtype dtype = Dtype::Float32);
Tensor from_vector(const std::vector<float>& values, const Shape& shape);
// From any Eigen matrix (copied into row-major order): an r x c matrix becomes shape {r, c}.
template <typename Derived>
Tensor from_eigen(const Eigen::MatrixBase<Derived>& m);
// Copy of a 1-d or 2-d tensor as an Eigen row-major matrix.
RowMatrixF to_eigen_float(const Tensor& t);
RowMatrixD to_eigen_double(const Tensor& t);
// The shape as error messages name it: "[2, 3]", or "an undefined tensor".
std::string shape_text(const Tensor& t);

// ----- template definitions -----

template <typename Derived>
Tensor from_eigen(const Eigen::MatrixBase<Derived>& m) {
  using T = typename Derived::Scalar;
  Tensor out = empty({m.rows(), m.cols()}, dtype_of<T>());
  out.matrix<T>() = m;
  return out;
}

}  // namespace maps::ag
