#include "autograd/kernels.h"

#include <stdexcept>

namespace maps::ag::detail {

void check_defined(const Tensor& t, const char* op, const char* name) {
  if (!t.defined()) throw std::invalid_argument(std::string(op) + ": the " + name + " is an undefined tensor");
}

void check_1d_layout(const Tensor& t, const char* op, const char* name) {
  check_defined(t, op, name);
  if (t.dim() != 3)
    throw std::invalid_argument(std::string(op) + ": expected " + name + " of shape [batch, channels, length], got " +
                                to_string(t.shape()));
}

namespace {
[[noreturn]] void dtypes_differ(const Tensor& a, const std::string& a_name, const Tensor& b, const std::string& b_name,
                                const char* op) {
  throw std::invalid_argument(std::string(op) + ": dtypes differ: " + a_name + to_string(a.shape()) + " " +
                              to_string(a.dtype()) + " and " + b_name + to_string(b.shape()) + " " +
                              to_string(b.dtype()) + " (convert one with .to())");
}
}  // namespace

void check_same_dtype(const Tensor& a, const Tensor& b, const char* op) {
  if (a.dtype() != b.dtype()) dtypes_differ(a, "", b, "", op);
}

void check_same_dtype(const Tensor& a, const char* a_name, const Tensor& b, const char* b_name, const char* op) {
  if (a.dtype() != b.dtype()) dtypes_differ(a, std::string(a_name) + " ", b, std::string(b_name) + " ", op);
}

BroadcastPlan plan_broadcast(const Shape& out, const Shape& a, const Shape& b) {
  BroadcastPlan plan;
  plan.out = out;
  const std::size_t rank = out.size();
  auto strides_for = [&](const Shape& s) {
    std::vector<std::int64_t> strides(rank, 0);
    const std::vector<std::int64_t> own = contiguous_strides(s);
    const std::size_t shift = rank - s.size();
    for (std::size_t i = shift; i < rank; ++i) strides[i] = s[i - shift] == 1 ? 0 : own[i - shift];
    return strides;
  };
  std::vector<std::int64_t> as = strides_for(a), bs = strides_for(b);
  if (rank == 0) {
    plan.inner = 1;
    return plan;
  }
  plan.inner = out[rank - 1];
  plan.a_step = as[rank - 1];
  plan.b_step = bs[rank - 1];
  as.pop_back();
  bs.pop_back();
  plan.a_strides = std::move(as);
  plan.b_strides = std::move(bs);
  return plan;
}

DimSplit split_at(const Shape& shape, std::int64_t dim) {
  DimSplit s{1, shape[dim], 1};
  for (std::int64_t i = 0; i < dim; ++i) s.outer *= shape[i];
  for (std::size_t i = dim + 1; i < shape.size(); ++i) s.inner *= shape[i];
  return s;
}

}  // namespace maps::ag::detail
