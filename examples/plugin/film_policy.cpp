// A multi-task policy: one MLP for every task whose hidden layer each task scales and shifts (FiLM, Perez et al.
// 2018): h = tanh(W1 s + b1) * (1 + gamma_k) + beta_k, action = W2 h + b2. gamma and beta start at 0, so every task
// starts from the same network. Its config section "film_mlp" has one key, "width" (the hidden layer's size).
#include <cstdint>
#include <memory>
#include <vector>

#include "maps/nn/linear.h"
#include "maps/policies/baseline_util.h"
#include "maps/policies/policy_registry.h"

namespace {

namespace ag = maps::ag;
namespace core = maps::core;

class FilmPolicy : public core::Policy {
 public:
  FilmPolicy(core::PolicyShape shape, std::int64_t width, ag::Generator& gen) : Policy("FilmPolicy", shape) {
    body_ = register_module("body", std::make_shared<maps::nn::Linear>(shape.observation_size, width, gen));
    gamma_ = register_parameter("gamma", ag::zeros({shape.num_tasks, width}));
    beta_ = register_parameter("beta", ag::zeros({shape.num_tasks, width}));
    head_ = register_module("head", std::make_shared<maps::nn::Linear>(width, shape.action_size, gen));
  }
  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override {
    core::detail::check_observations("FilmPolicy::act", shape(), observations, tasks);
    return forward(observations, tasks);
  }
  core::LossTerms loss(const core::Batch& batch) override {
    core::detail::check_batch("FilmPolicy::loss", shape(), batch);
    return core::detail::bc_terms(bc_loss(forward(batch.observations, batch.tasks), batch));
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<FilmPolicy>(*this); }

 private:
  ag::Tensor forward(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
    const ag::Tensor hidden = ag::tanh(child_at<maps::nn::Linear>(body_).forward(observations));
    const ag::Tensor scale = ag::index_select(parameter_at(gamma_), tasks) + 1.0;
    const ag::Tensor shift = ag::index_select(parameter_at(beta_), tasks);
    return child_at<maps::nn::Linear>(head_).forward(hidden * scale + shift);
  }
  std::size_t body_ = 0, gamma_ = 0, beta_ = 0, head_ = 0;
};

core::PolicyMethod film_method() {
  core::PolicyMethod method;
  method.name = "film_mlp";
  method.summary = "one MLP whose hidden layer each task scales and shifts (FiLM; an example plugin's method)";
  method.options = {maps::io::integer_option("width", 128, 1, 4096, "the hidden layer's size")};
  method.parameters = [](const core::PolicyShape& shape, const core::MethodOptions& options) {
    const double width = static_cast<double>(core::option_int(options.own, "width"));
    return core::mlp_parameter_count({shape.observation_size, static_cast<std::int64_t>(width), shape.action_size}) +
           2.0 * width * static_cast<double>(shape.num_tasks);
  };
  method.size_keys = "film_mlp.width";
  method.make = [](const core::PolicyShape& shape, const core::MethodOptions& options, ag::Generator& gen) {
    return std::shared_ptr<core::Policy>(
        std::make_shared<FilmPolicy>(shape, core::option_int(options.own, "width"), gen));
  };
  return method;
}

}  // namespace

MAPS_REGISTER_POLICY_METHOD(film_method());
