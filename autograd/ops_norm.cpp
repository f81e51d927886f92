// Group normalisation as one op: composed of means, squares and divisions it took a tenth of Diffusion Policy's
// U-Net step (issue 46). The first-order rule is one pass too; under create_graph the rule is written in ops instead,
// so that it has derivatives of its own.
#include <cmath>
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

// x [batch, channels, ...] as [batch * groups, members]: each group's channels are contiguous.
struct Groups {
  std::int64_t count, members;
};

Groups groups_of(const Tensor& x, std::int64_t groups) {
  return {x.size(0) * groups, x.size(0) == 0 ? 0 : x.numel() / (x.size(0) * groups)};
}

// The rule dx = (g - mean(g) - y mean(g y)) / std over each group, written in ops from x, so that create_graph's
// graph of it has derivatives of its own.
Tensor group_norm_backward_in_ops(const Tensor& grad, const Tensor& x, std::int64_t groups, double eps) {
  const Shape grouped{x.size(0), groups, -1};
  const Tensor centred = sub(reshape(x, grouped), mean(reshape(x, grouped), {2}, true));
  const Tensor inverse_std = rdiv(1.0, sqrt(add(mean(square(centred), {2}, true), eps)));
  const Tensor y = mul(centred, inverse_std);
  const Tensor g = reshape(grad, grouped);
  const Tensor dx = mul(sub(sub(g, mean(g, {2}, true)), mul(y, mean(mul(g, y), {2}, true))), inverse_std);
  return reshape(dx, x.shape());
}

}  // namespace

Tensor group_norm(const Tensor& x, std::int64_t groups, double eps) {
  detail::check_defined(x, "group_norm", "input");
  if (x.dim() < 2)
    throw std::invalid_argument("group_norm: expected x of shape [batch, channels, ...], got " + to_string(x.shape()));
  const std::int64_t channels = x.size(1);
  if (groups < 1 || channels % groups != 0)
    throw std::invalid_argument("group_norm: " + std::to_string(channels) + " channels do not split into " +
                                std::to_string(groups) + " groups");
  if (!(eps > 0.0)) throw std::invalid_argument("group_norm: eps must be > 0, got " + std::to_string(eps));
  const Groups g = groups_of(x, groups);
  if (g.members == 0) throw std::invalid_argument("group_norm: x of shape " + to_string(x.shape()) + " is empty");
  Tensor out = empty(x.shape(), x.dtype());
  Tensor inverse_std = empty({g.count}, x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    const T* in = x.data<T>();
    T* o = out.data<T>();
    T* r = inverse_std.data<T>();
    parallel_for(g.count, 1, [&](std::int64_t first, std::int64_t last) {
      for (std::int64_t i = first; i < last; ++i) {
        const Eigen::Map<const Array> v(in + i * g.members, g.members);
        Eigen::Map<Array> y(o + i * g.members, g.members);
        const T mu = v.mean();
        y = v - mu;  // two passes, as the ops compute it: no cancellation in the variance
        r[i] = T(1) / std::sqrt(y.square().mean() + static_cast<T>(eps));
        y *= r[i];
      }
    });
  });
  return record(
      "group_norm", out, {x},
      [x, groups, eps, inverse_std, g](const Tensor& grad, const Needs&, Node& self) {
        if (GradMode::is_enabled()) return Grads{group_norm_backward_in_ops(grad, x, groups, eps)};  // create_graph
        // dx = (g - mean(g) - y mean(g y)) / std over each group.
        const Tensor y = self.output();
        Tensor dx = empty(x.shape(), x.dtype());
        dispatch_dtype(x.dtype(), [&](auto tag) {
          using T = typename decltype(tag)::type;
          using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
          const T* gp = grad.data<T>();
          const T* yp = y.data<T>();
          const T* r = inverse_std.data<T>();
          T* d = dx.data<T>();
          parallel_for(g.count, 1, [&](std::int64_t first, std::int64_t last) {
            for (std::int64_t i = first; i < last; ++i) {
              const Eigen::Map<const Array> gv(gp + i * g.members, g.members), yv(yp + i * g.members, g.members);
              const T mean_g = gv.mean(), mean_gy = (gv * yv).mean();
              Eigen::Map<Array>(d + i * g.members, g.members) = (gv - mean_g - yv * mean_gy) * r[i];
            }
          });
        });
        return Grads{dx};
      },
      true);
}

}  // namespace maps::ag
