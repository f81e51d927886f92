#include "maps/training/init_from_run.h"

#include <algorithm>
#include <stdexcept>

namespace maps::core {

void initialize_from(Policy& target, const std::vector<std::string>& target_tasks, const Policy& source,
                     const std::vector<std::string>& source_tasks) {
  const nn::NamedTensors to = target.named_parameters(), from = source.named_parameters();
  const auto S = target.shape().observation_size;
  const auto K_to = static_cast<std::int64_t>(target_tasks.size()),
             K_from = static_cast<std::int64_t>(source_tasks.size());
  if (source.shape().observation_size != S || source.shape().action_size != target.shape().action_size)
    throw std::invalid_argument("initialize_from: the source policy is for observations " +
                                std::to_string(source.shape().observation_size) + " and actions " +
                                std::to_string(source.shape().action_size) + ", the target for " + std::to_string(S) +
                                " and " + std::to_string(target.shape().action_size));
  ag::NoGradGuard no_grad;
  for (const auto& [name, tensor] : to) {
    const auto found =
        std::find_if(from.begin(), from.end(), [&name = name](const nn::NamedTensor& p) { return p.name == name; });
    if (found == from.end())
      throw std::invalid_argument("initialize_from: the source " + source.type_name() + " has no parameter " + name);
    const ag::Tensor& src = found->tensor;
    ag::Tensor dst = tensor;
    const bool task_input = dst.dim() == 2 && src.dim() == 2 && dst.size(0) == src.size(0) && dst.size(1) == S + K_to &&
                            src.size(1) == S + K_from;
    // A [state, task] layer is mapped by task name even when its shape is the same (other tasks, or another order).
    if (src.shape() == dst.shape() && (!task_input || target_tasks == source_tasks)) {
      dst.copy_(src.to(dst.dtype()));
      continue;
    }
    if (!task_input)
      throw std::invalid_argument("initialize_from: parameter " + name + " is " + ag::shape_text(src) +
                                  " in the source and " + ag::shape_text(dst) +
                                  " here, and is not a [state, task] input "
                                  "layer that differs only in its tasks");
    const ag::RowMatrixD from_weight = ag::to_eigen_double(src);
    ag::RowMatrixD weight(dst.size(0), S + K_to);
    weight.leftCols(S) = from_weight.leftCols(S);
    const Eigen::VectorXd mean_task = from_weight.rightCols(K_from).rowwise().mean();
    for (std::int64_t k = 0; k < K_to; ++k) {
      const auto known = std::find(source_tasks.begin(), source_tasks.end(), target_tasks[static_cast<std::size_t>(k)]);
      weight.col(S + k) = known == source_tasks.end() ? mean_task : from_weight.col(S + (known - source_tasks.begin()));
    }
    dst.copy_(ag::from_eigen(weight).to(dst.dtype()));
  }
  if (from.size() != to.size())
    for (const auto& p : from)
      if (std::none_of(to.begin(), to.end(), [&](const nn::NamedTensor& q) { return q.name == p.name; }))
        throw std::invalid_argument("initialize_from: this " + target.type_name() + " has no parameter " + p.name +
                                    " of the source's");
}

}  // namespace maps::core
