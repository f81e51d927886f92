// Ops that move or copy elements without arithmetic: reshape, transpose, expand, concat,
// stack, narrow, index_select and their adjoints.
#include <cstring>
#include <stdexcept>
#include <string>

#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {
std::size_t bytes_of(const Tensor& t, std::int64_t elements) {
  return static_cast<std::size_t>(elements) * element_size(t.dtype());
}
char* bytes_ptr(const Tensor& t) { return static_cast<char*>(t.impl()->storage->data()); }
}  // namespace

Tensor reshape(const Tensor& x, const Shape& shape) {
  detail::check_defined(x, "reshape", "input");
  Shape target = shape;
  std::int64_t known = 1;
  int inferred = -1;
  for (std::size_t i = 0; i < target.size(); ++i) {
    if (target[i] == -1) {
      if (inferred >= 0) throw std::invalid_argument("reshape: only one dim may be -1 in " + to_string(shape));
      inferred = static_cast<int>(i);
    } else if (target[i] < 0) {
      throw std::invalid_argument("reshape: invalid size in " + to_string(shape));
    } else {
      known *= target[i];
    }
  }
  if (inferred >= 0) {
    if (known == 0 || x.numel() % known != 0) {
      throw std::invalid_argument("reshape: cannot view " + to_string(x.shape()) + " as " + to_string(shape));
    }
    target[inferred] = x.numel() / known;
  }
  if (numel_of(target) != x.numel()) {
    throw std::invalid_argument("reshape: cannot view " + to_string(x.shape()) + " (" + std::to_string(x.numel()) +
                                " elements) as " + to_string(shape));
  }
  if (target == x.shape()) return x;
  auto impl = std::make_shared<TensorImpl>();
  impl->shape = target;
  impl->dtype = x.dtype();
  impl->storage = x.impl()->storage;  // contiguous, so a reshape is a view
  return record(
      "reshape", Tensor(impl), {x},
      [original = x.shape()](const Tensor& g, const Needs&, Node&) { return Grads{reshape(g, original)}; }, false,
      Reads::none());
}

Tensor transpose(const Tensor& x, std::int64_t dim0, std::int64_t dim1) {
  detail::check_defined(x, "transpose", "input");
  const std::int64_t rank = x.dim();
  const std::int64_t d0 = normalize_dim(dim0, rank, "transpose");
  const std::int64_t d1 = normalize_dim(dim1, rank, "transpose");
  if (d0 == d1) return x;
  Shape out_shape = x.shape();
  std::swap(out_shape[d0], out_shape[d1]);
  Tensor out = empty(out_shape, x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Mat = RowMatrix<T>;
    const T* src = x.data<T>();
    T* dst = out.data<T>();
    if (std::min(d0, d1) == rank - 2 && std::max(d0, d1) == rank - 1) {
      // Swapping the two innermost dims: a batch of matrix transposes.
      const std::int64_t r = x.size(-2), c = x.size(-1), batch = x.numel() / std::max<std::int64_t>(1, r * c);
      for (std::int64_t i = 0; i < batch; ++i) {
        Eigen::Map<Mat>(dst + i * r * c, c, r) = Eigen::Map<const Mat>(src + i * r * c, r, c).transpose();
      }
      return;
    }
    // General case: walk the output in order, stepping the input with permuted strides.
    std::vector<std::int64_t> in_strides = contiguous_strides(x.shape());
    std::swap(in_strides[d0], in_strides[d1]);
    std::vector<std::int64_t> index(rank, 0);
    std::int64_t offset = 0;
    for (std::int64_t i = 0, n = out.numel(); i < n; ++i) {
      dst[i] = src[offset];
      for (std::int64_t d = rank; d-- > 0;) {
        ++index[d];
        offset += in_strides[d];
        if (index[d] < out_shape[d]) break;
        offset -= in_strides[d] * out_shape[d];
        index[d] = 0;
      }
    }
  });
  return record(
      "transpose", out, {x}, [d0, d1](const Tensor& g, const Needs&, Node&) { return Grads{transpose(g, d0, d1)}; },
      false, Reads::none());
}

Tensor expand(const Tensor& x, const Shape& shape) {
  detail::check_defined(x, "expand", "input");
  if (x.shape() == shape) return x;
  if (shape.size() < x.shape().size() || broadcast_shapes(x.shape(), shape, "expand") != shape) {
    throw std::invalid_argument("expand: cannot expand " + to_string(x.shape()) + " to " + to_string(shape));
  }
  Tensor out = empty(shape, x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    const T* src = x.data<T>();
    T* dst = out.data<T>();
    const detail::BroadcastPlan plan = detail::plan_broadcast(shape, x.shape(), x.shape());
    detail::for_each_broadcast_row(plan, [&](const detail::BroadcastRow& row) {
      Eigen::Map<Array> o(dst + row.out_offset, plan.inner);
      if (plan.a_step == 1) {
        o = Eigen::Map<const Array>(src + row.a_offset, plan.inner);
      } else {
        o.setConstant(src[row.a_offset]);
      }
    });
  });
  return record(
      "expand", out, {x},
      [original = x.shape()](const Tensor& g, const Needs&, Node&) { return Grads{sum_to(g, original)}; }, false,
      Reads::none());
}

Tensor sum_to(const Tensor& x, const Shape& shape) {
  detail::check_defined(x, "sum_to", "input");
  if (x.shape() == shape) return x;
  const Shape& from = x.shape();
  if (shape.size() > from.size() || broadcast_shapes(shape, from, "sum_to") != from) {
    throw std::invalid_argument("sum_to: cannot sum " + to_string(from) + " down to " + to_string(shape));
  }
  const std::size_t lead = from.size() - shape.size();
  std::vector<std::int64_t> dims;
  for (std::size_t i = 0; i < from.size(); ++i) {
    if (i < lead || (shape[i - lead] == 1 && from[i] != 1)) dims.push_back(static_cast<std::int64_t>(i));
  }
  return reshape(dims.empty() ? x : sum(x, dims, /*keepdim=*/true), shape);
}

Tensor concat(const std::vector<Tensor>& tensors, std::int64_t dim) {
  if (tensors.empty()) throw std::invalid_argument("concat: no tensors were given");
  const Tensor& first = tensors[0];
  detail::check_defined(first, "concat", "first tensor");
  const std::int64_t rank = first.dim();
  if (rank == 0) throw std::invalid_argument("concat: cannot concatenate 0-d tensors (use stack)");
  const std::int64_t d = normalize_dim(dim, rank, "concat");
  Shape out_shape = first.shape();
  out_shape[d] = 0;
  for (std::size_t i = 0; i < tensors.size(); ++i) {
    const Tensor& t = tensors[i];
    detail::check_defined(t, "concat", "tensor");
    detail::check_same_dtype(first, t, "concat");
    bool fits = t.dim() == rank;
    for (std::int64_t j = 0; fits && j < rank; ++j) fits = j == d || t.shape()[j] == first.shape()[j];
    if (!fits) {
      throw std::invalid_argument("concat: tensor " + std::to_string(i) + " of shape " + to_string(t.shape()) +
                                  " does not match " + to_string(first.shape()) + " outside dim " + std::to_string(d));
    }
    out_shape[d] += t.shape()[d];
  }
  Tensor out = empty(out_shape, first.dtype());
  const detail::DimSplit split = detail::split_at(out_shape, d);
  std::vector<std::int64_t> starts, sizes;  // each input's place along dim d, for the backward rule
  std::int64_t start = 0;
  for (const Tensor& t : tensors) {
    const std::int64_t size = t.shape()[d], chunk = size * split.inner;
    for (std::int64_t o = 0; o < split.outer; ++o) {
      std::memcpy(bytes_ptr(out) + bytes_of(out, (o * split.size + start) * split.inner),
                  bytes_ptr(t) + bytes_of(t, o * chunk), bytes_of(t, chunk));
    }
    starts.push_back(start);
    sizes.push_back(size);
    start += size;
  }
  return record(
      "concat", out, tensors,
      [d, starts, sizes](const Tensor& g, const Needs& need, Node&) {
        Grads grads(sizes.size());
        for (std::size_t i = 0; i < sizes.size(); ++i) {
          if (need[i]) grads[i] = narrow(g, d, starts[i], sizes[i]);
        }
        return grads;
      },
      false, Reads::none());
}

Tensor stack(const std::vector<Tensor>& tensors, std::int64_t dim) {
  if (tensors.empty()) throw std::invalid_argument("stack: no tensors were given");
  detail::check_defined(tensors[0], "stack", "first tensor");
  const Shape& shape = tensors[0].shape();
  const std::int64_t d = normalize_dim(dim, static_cast<std::int64_t>(shape.size()) + 1, "stack");
  std::vector<Tensor> expanded;
  for (std::size_t i = 0; i < tensors.size(); ++i) {
    detail::check_defined(tensors[i], "stack", "tensor");
    if (tensors[i].shape() != shape) {
      throw std::invalid_argument("stack: tensor " + std::to_string(i) + " has shape " + to_string(tensors[i].shape()) +
                                  " but tensor 0 has " + to_string(shape));
    }
    Shape with_dim = shape;
    with_dim.insert(with_dim.begin() + d, 1);
    expanded.push_back(reshape(tensors[i], with_dim));
  }
  return concat(expanded, d);
}

Tensor narrow(const Tensor& x, std::int64_t dim, std::int64_t start, std::int64_t length) {
  detail::check_defined(x, "narrow", "input");
  const std::int64_t d = normalize_dim(dim, x.dim(), "narrow");
  const std::int64_t size = x.shape()[d];
  if (start < 0 || length < 0 || start > size || length > size - start) {
    throw std::invalid_argument("narrow: start " + std::to_string(start) + " and length " + std::to_string(length) +
                                " do not fit dim " + std::to_string(d) + " of size " + std::to_string(size) +
                                " in shape " + to_string(x.shape()));
  }
  if (start == 0 && length == size) return x;
  Shape out_shape = x.shape();
  out_shape[d] = length;
  Tensor out = empty(out_shape, x.dtype());
  const detail::DimSplit split = detail::split_at(x.shape(), d);
  const std::int64_t chunk = length * split.inner;
  for (std::int64_t o = 0; o < split.outer; ++o) {
    std::memcpy(bytes_ptr(out) + bytes_of(out, o * chunk), bytes_ptr(x) + bytes_of(x, (o * size + start) * split.inner),
                bytes_of(x, chunk));
  }
  return record(
      "narrow", out, {x},
      [d, start, length, full = x.shape()](const Tensor& g, const Needs&, Node&) {
        // The adjoint pads the gradient with zeros back to the full size.
        std::vector<Tensor> parts;
        Shape pad = full;
        if (start > 0) {
          pad[d] = start;
          parts.push_back(zeros(pad, g.dtype()));
        }
        parts.push_back(g);
        if (start + length < full[d]) {
          pad[d] = full[d] - start - length;
          parts.push_back(zeros(pad, g.dtype()));
        }
        return Grads{parts.size() == 1 ? g : concat(parts, d)};
      },
      false, Reads::none());
}

namespace {
void check_indices(const std::vector<std::int64_t>& indices, std::int64_t rows, const char* op) {
  for (std::size_t i = 0; i < indices.size(); ++i) {
    if (indices[i] < 0 || indices[i] >= rows) {
      throw std::out_of_range(std::string(op) + ": index " + std::to_string(indices[i]) + " at position " +
                              std::to_string(i) + " is outside [0, " + std::to_string(rows) + ")");
    }
  }
}
}  // namespace

Tensor index_select(const Tensor& x, const std::vector<std::int64_t>& indices) {
  detail::check_defined(x, "index_select", "input");
  if (x.dim() == 0) throw std::invalid_argument("index_select: the input is 0-d");
  const std::int64_t rows = x.size(0);
  check_indices(indices, rows, "index_select");
  Shape out_shape = x.shape();
  out_shape[0] = static_cast<std::int64_t>(indices.size());
  Tensor out = empty(out_shape, x.dtype());
  const std::int64_t row = rows == 0 ? 0 : x.numel() / rows;
  for (std::size_t i = 0; i < indices.size(); ++i) {
    std::memcpy(bytes_ptr(out) + bytes_of(out, static_cast<std::int64_t>(i) * row),
                bytes_ptr(x) + bytes_of(x, indices[i] * row), bytes_of(x, row));
  }
  return record(
      "index_select", out, {x},
      [indices, rows](const Tensor& g, const Needs&, Node&) { return Grads{index_add(g, indices, rows)}; }, false,
      Reads::none());
}

Tensor index_add(const Tensor& source, const std::vector<std::int64_t>& indices, std::int64_t rows) {
  detail::check_defined(source, "index_add", "source");
  if (source.dim() == 0 || source.size(0) != static_cast<std::int64_t>(indices.size())) {
    throw std::invalid_argument("index_add: source of shape " + to_string(source.shape()) +
                                " needs one row per index (" + std::to_string(indices.size()) + " indices)");
  }
  if (rows < 0) throw std::invalid_argument("index_add: rows must not be negative, got " + std::to_string(rows));
  check_indices(indices, rows, "index_add");
  Shape out_shape = source.shape();
  out_shape[0] = rows;
  Tensor out = zeros(out_shape, source.dtype());
  const std::int64_t row = numel_of(out_shape) / std::max<std::int64_t>(1, rows);
  dispatch_dtype(source.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    // Rows may repeat, so the threads split the columns (each adds its own slice of every row).
    const std::int64_t work = static_cast<std::int64_t>(indices.size()) * row;
    const std::int64_t grain = work < 2 * detail::kElementwiseGrain ? row : 16;
    parallel_for(row, grain, [&](std::int64_t c0, std::int64_t c1) {
      for (std::size_t i = 0; i < indices.size(); ++i) {
        Eigen::Map<Array>(out.data<T>() + indices[i] * row + c0, c1 - c0) +=
            Eigen::Map<const Array>(source.data<T>() + static_cast<std::int64_t>(i) * row + c0, c1 - c0);
      }
    });
  });
  return record(
      "index_add", out, {source},
      [indices](const Tensor& g, const Needs&, Node&) { return Grads{index_select(g, indices)}; }, false,
      Reads::none());
}

}  // namespace maps::ag
