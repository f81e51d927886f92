#pragma once

#include <functional>
#include <string>
#include <vector>

#include "autograd/tensor.h"

namespace maps::ag {

// PyTorch's defaults, meant for float64 inputs.
struct GradcheckOptions {
  double eps = 1e-6;
  double atol = 1e-5;
  double rtol = 1e-3;
};

struct GradcheckResult {
  bool ok = true;
  std::string message;  // names the op, the input, the output and input elements and both values
};

using MultiFunction = std::function<std::vector<Tensor>(const std::vector<Tensor>&)>;
using SingleFunction = std::function<Tensor(const std::vector<Tensor>&)>;

// Compares the analytic Jacobian (one backward pass per output element) with central
// differences, for every element of every input that requires grad. Inputs must be float64.
GradcheckResult gradcheck(const std::string& op, const MultiFunction& f, const std::vector<Tensor>& inputs,
                          const GradcheckOptions& options = {});
GradcheckResult gradcheck(const std::string& op, const SingleFunction& f, const std::vector<Tensor>& inputs,
                          const GradcheckOptions& options = {});

// Checks second derivatives: gradchecks the map (inputs, v) -> grad(f(inputs), inputs, v,
// create_graph) with random float64 grad_outputs v drawn from `seed`.
GradcheckResult gradgradcheck(const std::string& op, const MultiFunction& f, const std::vector<Tensor>& inputs,
                              const GradcheckOptions& options = {}, unsigned seed = 0);
GradcheckResult gradgradcheck(const std::string& op, const SingleFunction& f, const std::vector<Tensor>& inputs,
                              const GradcheckOptions& options = {}, unsigned seed = 0);

}  // namespace maps::ag
