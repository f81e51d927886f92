// Losses and encodings.
#include <stdexcept>
#include <string>

#include "autograd/kernels.h"
#include "autograd/ops.h"

namespace maps::ag {

Tensor mse_loss(const Tensor& prediction, const Tensor& target) {
  detail::check_defined(prediction, "mse_loss", "prediction");
  detail::check_defined(target, "mse_loss", "target");
  // PyTorch broadcasts here with a warning; a silent broadcast of a [B,1] target over [B,A] is a
  // classic wrong-loss bug, so shapes must match exactly.
  if (prediction.shape() != target.shape()) {
    throw std::invalid_argument("mse_loss: prediction of shape " + to_string(prediction.shape()) +
                                " and target of shape " + to_string(target.shape()) + " differ");
  }
  detail::check_same_dtype(prediction, target, "mse_loss");
  return mean(square(sub(prediction, target)));
}

Tensor one_hot(const std::vector<std::int64_t>& indices, std::int64_t classes, Dtype dtype) {
  if (classes <= 0) throw std::invalid_argument("one_hot: classes must be positive, got " + std::to_string(classes));
  Tensor out = zeros({static_cast<std::int64_t>(indices.size()), classes}, dtype);
  for (std::size_t i = 0; i < indices.size(); ++i) {
    if (indices[i] < 0 || indices[i] >= classes) {
      throw std::out_of_range("one_hot: index " + std::to_string(indices[i]) + " at position " + std::to_string(i) +
                              " is outside [0, " + std::to_string(classes) + ")");
    }
    dispatch_dtype(dtype, [&](auto tag) {
      using T = typename decltype(tag)::type;
      out.data<T>()[static_cast<std::int64_t>(i) * classes + indices[i]] = T(1);
    });
  }
  return out;
}

}  // namespace maps::ag
