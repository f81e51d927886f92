// A user's program against the installed library: a new op written as a composition of the engine's ops,
// gradchecked and gradgradchecked in float64, an MLP trained for a few steps, and an env with its expert from the
// installed assets (install_test.sh points MAPS_ASSETS_DIR and MAPS_EXPERTS_DIR there). Exits non-zero on a failure.
#include <cmath>
#include <cstdio>

#include "maps/autograd/autograd.h"
#include "maps/envs/task_expert.h"
#include "maps/envs/task_sets.h"
#include "maps/nn/mlp.h"
#include "maps/nn/optim/adam.h"
#include "nn/mlp.h"  // the user's own

namespace ag = maps::ag;

// log_cosh(x) = log((exp(x) + exp(-x)) / 2), the user's own op (a name the library does not have: the argument's
// namespace is searched too, so a user's op named like one of ag's would be ambiguous).
ag::Tensor log_cosh(const ag::Tensor& x) { return ag::log((ag::exp(x) + ag::exp(-x)) * 0.5); }

int main() {
  ag::Generator gen(7);
  const ag::Tensor x = ag::randn({3, 4}, gen, ag::Dtype::Float64).requires_grad_(true);
  const auto f = [](const std::vector<ag::Tensor>& in) { return log_cosh(in[0]); };
  const ag::GradcheckResult first = ag::gradcheck("log_cosh", f, {x});
  const ag::GradcheckResult second = ag::gradgradcheck("log_cosh", f, {x});
  if (!first.ok || !second.ok) {
    std::printf("gradcheck failed: %s %s\n", first.message.c_str(), second.message.c_str());
    return 1;
  }

  const ag::Tensor inputs = ag::rand({64, 2}, gen, ag::Dtype::Float32, -1.0, 1.0);
  const ag::Tensor targets = ag::sum(inputs * inputs, {1}, true);
  maps::nn::MLP mlp({2, 16, 1}, "tanh", gen);
  maps::optim::Adam adam(mlp.parameters(), {.lr = 1e-2});
  double loss_first = 0.0, loss_last = 0.0;
  for (int step = 0; step < 50; ++step) {
    adam.zero_grad();
    ag::Tensor loss = ag::mse_loss(mlp.forward(inputs), targets);
    loss.backward();
    adam.step();
    (step == 0 ? loss_first : loss_last) = loss.item();
  }
  std::printf("log_cosh: gradcheck and gradgradcheck passed; MLP loss %.4f -> %.4f over 50 Adam steps\n", loss_first,
              loss_last);
  if (!(loss_last < loss_first)) return 1;

  const auto env = maps::envs::make_env("gravity/1.0");
  const maps::envs::TaskExpert expert = maps::envs::load_task_expert("gravity/1.0");
  Eigen::VectorXd obs = env->reset(0);
  double episode_return = 0.0;
  for (int t = 0; t < env->spec().horizon; ++t) {
    const maps::envs::StepResult step = env->step(expert.mean_action(obs));
    episode_return += step.reward;
    obs = step.observation;
  }
  std::printf("gravity/1.0 from the installed assets: the installed expert returns %.0f over %d steps (%s beside it)\n",
              episode_return, env->spec().horizon, user::kWhoseMlp);
  return episode_return > 1000.0 ? 0 : 1;
}
