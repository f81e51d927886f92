#include "autograd/gradcheck.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "autograd/engine.h"
#include "autograd/generator.h"
#include "autograd/grad_mode.h"
#include "autograd/ops.h"

namespace maps::ag {

namespace {

std::vector<std::size_t> differentiable_inputs(const std::string& op, const std::vector<Tensor>& inputs) {
  std::vector<std::size_t> which;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    if (!inputs[i].defined())
      throw std::invalid_argument("gradcheck(" + op + "): input " + std::to_string(i) + " is undefined");
    if (!inputs[i].requires_grad()) continue;
    if (inputs[i].dtype() != Dtype::Float64) {
      throw std::invalid_argument("gradcheck(" + op + "): input " + std::to_string(i) +
                                  " is float32; gradients are checked in float64");
    }
    if (!inputs[i].is_leaf()) {
      throw std::invalid_argument("gradcheck(" + op + "): input " + std::to_string(i) + " must be a leaf");
    }
    which.push_back(i);
  }
  if (which.empty()) throw std::invalid_argument("gradcheck(" + op + "): no input requires grad");
  return which;
}

std::vector<double> flatten(const std::vector<Tensor>& outputs) {
  std::vector<double> flat;
  for (const Tensor& t : outputs) {
    const std::vector<double> v = t.to_vector();
    flat.insert(flat.end(), v.begin(), v.end());
  }
  return flat;
}

}  // namespace

GradcheckResult gradcheck(const std::string& op, const MultiFunction& f, const std::vector<Tensor>& inputs,
                          const GradcheckOptions& options) {
  const std::vector<std::size_t> diff = differentiable_inputs(op, inputs);
  const std::vector<Tensor> outputs = f(inputs);
  std::vector<Tensor> diff_inputs;
  for (std::size_t i : diff) diff_inputs.push_back(inputs[i]);

  // analytic[input][out_element * numel(input) + in_element], one backward pass per output element.
  std::vector<std::vector<double>> analytic(diff.size());
  std::int64_t total_out = 0;
  for (const Tensor& out : outputs) total_out += out.numel();
  for (std::size_t k = 0; k < diff.size(); ++k) analytic[k].assign(total_out * inputs[diff[k]].numel(), 0.0);

  std::vector<Tensor> graph_outputs;
  std::vector<std::size_t> graph_index;
  for (std::size_t o = 0; o < outputs.size(); ++o) {
    if (outputs[o].requires_grad()) {
      graph_outputs.push_back(outputs[o]);
      graph_index.push_back(o);
    }
  }
  std::int64_t row = 0;
  for (std::size_t o = 0; o < outputs.size(); ++o) {
    const auto slot = std::find(graph_index.begin(), graph_index.end(), o);
    for (std::int64_t j = 0; j < outputs[o].numel(); ++j, ++row) {
      if (slot == graph_index.end()) continue;  // an output the inputs do not reach: its Jacobian is 0
      std::vector<Tensor> seeds;
      for (const Tensor& g : graph_outputs) seeds.push_back(zeros_like(g));
      Tensor& seed = seeds[slot - graph_index.begin()];
      seed.data<double>()[j] = 1.0;
      const std::vector<Tensor> grads = grad(graph_outputs, diff_inputs, seeds, /*retain_graph=*/true,
                                             /*create_graph=*/false, /*allow_unused=*/true);
      for (std::size_t k = 0; k < diff.size(); ++k) {
        if (!grads[k].defined()) continue;
        const std::int64_t n = inputs[diff[k]].numel();
        for (std::int64_t e = 0; e < n; ++e) analytic[k][row * n + e] = grads[k].at(e);
      }
    }
  }

  GradcheckResult result;
  std::ostringstream failures;
  int failed = 0;
  // f runs with grad mode on even here: in gradgradcheck f itself calls grad().
  for (std::size_t k = 0; k < diff.size(); ++k) {
    Tensor input = inputs[diff[k]];
    double* values = input.data<double>();
    const std::int64_t n = input.numel();
    for (std::int64_t e = 0; e < n; ++e) {
      const double original = values[e];
      values[e] = original + options.eps;
      const std::vector<double> plus = flatten(f(inputs));
      values[e] = original - options.eps;
      const std::vector<double> minus = flatten(f(inputs));
      values[e] = original;
      for (std::int64_t r = 0; r < total_out; ++r) {
        const double numerical = (plus[r] - minus[r]) / (2.0 * options.eps);
        const double a = analytic[k][r * n + e];
        const bool close = std::abs(a - numerical) <= options.atol + options.rtol * std::abs(numerical);
        if (!close || std::isnan(a) != std::isnan(numerical)) {
          if (failed < 5) {
            failures << "\n  d output[" << r << "] / d input " << diff[k] << " (shape " << to_string(input.shape())
                     << ") element " << e << ": analytic " << a << " vs numerical " << numerical;
          }
          ++failed;
        }
      }
    }
  }
  if (failed > 0) {
    result.ok = false;
    std::ostringstream message;
    message << "gradcheck failed for op '" << op << "': " << failed << " Jacobian entries differ beyond atol "
            << options.atol << " + rtol " << options.rtol << " (eps " << options.eps << ")" << failures.str();
    if (failed > 5) message << "\n  ...";
    result.message = message.str();
  }
  return result;
}

GradcheckResult gradcheck(const std::string& op, const SingleFunction& f, const std::vector<Tensor>& inputs,
                          const GradcheckOptions& options) {
  return gradcheck(op, MultiFunction([&f](const std::vector<Tensor>& x) { return std::vector<Tensor>{f(x)}; }), inputs,
                   options);
}

GradcheckResult gradgradcheck(const std::string& op, const MultiFunction& f, const std::vector<Tensor>& inputs,
                              const GradcheckOptions& options, unsigned seed) {
  const std::vector<std::size_t> diff = differentiable_inputs(op, inputs);
  // f runs with grad mode on: it may itself call grad() (a MAML meta-loss does).
  const std::vector<Tensor> outputs = f(inputs);
  std::vector<Tensor> grad_outputs;
  Generator gen(seed);
  for (const Tensor& out : outputs) grad_outputs.push_back(randn(out.shape(), gen, Dtype::Float64).requires_grad_());
  const std::size_t n_inputs = inputs.size();
  // The first-order gradient as a function of (inputs, grad_outputs), built with create_graph.
  MultiFunction first_order = [&f, &diff, n_inputs](const std::vector<Tensor>& all) {
    const std::vector<Tensor> x(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(n_inputs));
    const std::vector<Tensor> v(all.begin() + static_cast<std::ptrdiff_t>(n_inputs), all.end());
    const std::vector<Tensor> outs = f(x);
    std::vector<Tensor> graph_outs, graph_v;
    for (std::size_t o = 0; o < outs.size(); ++o) {
      if (outs[o].requires_grad()) {
        graph_outs.push_back(outs[o]);
        graph_v.push_back(v[o]);
      }
    }
    std::vector<Tensor> diff_x;
    for (std::size_t i : diff) diff_x.push_back(x[i]);
    std::vector<Tensor> grads(diff.size());
    if (!graph_outs.empty()) {
      grads = grad(graph_outs, diff_x, graph_v, /*retain_graph=*/true, /*create_graph=*/true, /*allow_unused=*/true);
    }
    for (std::size_t k = 0; k < grads.size(); ++k) {
      if (!grads[k].defined()) grads[k] = zeros_like(diff_x[k]);
    }
    return grads;
  };
  std::vector<Tensor> all = inputs;
  all.insert(all.end(), grad_outputs.begin(), grad_outputs.end());
  return gradcheck(op + " (second order)", first_order, all, options);
}

GradcheckResult gradgradcheck(const std::string& op, const SingleFunction& f, const std::vector<Tensor>& inputs,
                              const GradcheckOptions& options, unsigned seed) {
  return gradgradcheck(op, MultiFunction([&f](const std::vector<Tensor>& x) { return std::vector<Tensor>{f(x)}; }),
                       inputs, options, seed);
}

}  // namespace maps::ag
