#include "maps/policies/diffusion_policy.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "envs/portable_random.h"
#include "maps/diffusion/ddpm.h"
#include "maps/diffusion/mlp_denoiser.h"
#include "maps/diffusion/modular_denoiser.h"
#include "maps/diffusion/sparse_moe_denoiser.h"
#include "maps/diffusion/unet1d.h"
#include "maps/policies/policy_registry.h"

namespace maps::core {
namespace {

constexpr std::int64_t kUnetKernel = 5;
constexpr std::int64_t kUnetGroups = 8;

std::int64_t condition_size(const PolicyShape& shape, const DiffusionPolicyConfig& c) {
  return shape.observation_size * c.observations + shape.num_tasks;
}

// About a quarter of the width, even (sinusoidal pairs), at least 16.
std::int64_t mlp_step_embedding(std::int64_t width) { return 2 * std::max<std::int64_t>(8, width / 8); }

diffusion::Unet1dConfig unet_config(const PolicyShape& shape, const DiffusionPolicyConfig& c) {
  diffusion::Unet1dConfig u;
  u.action_dim = shape.action_size / c.horizon;
  u.cond_dim = condition_size(shape, c);
  u.step_embed_dim = c.width;
  u.down_dims = {c.width, 2 * c.width, 4 * c.width};
  u.kernel = kUnetKernel;
  u.groups = kUnetGroups;
  return u;
}

diffusion::MlpDenoiserConfig mlp_config(const PolicyShape& shape, const DiffusionPolicyConfig& c) {
  diffusion::MlpDenoiserConfig m;
  m.horizon = c.horizon;
  m.action_dim = shape.action_size / c.horizon;
  m.cond_dim = condition_size(shape, c);
  m.step_embed_dim = mlp_step_embedding(c.width);
  m.hidden.assign(static_cast<std::size_t>(c.layers), c.width);
  return m;
}

diffusion::ModularDenoiserConfig modular_config(const PolicyShape& shape, const DiffusionPolicyConfig& c) {
  diffusion::ModularDenoiserConfig m;
  m.horizon = c.horizon;
  m.action_dim = shape.action_size / c.horizon;
  m.state_size = shape.observation_size;
  m.cond_dim = condition_size(shape, c);
  m.num_tasks = shape.num_tasks;
  m.modules = c.maps.modules;
  m.module_hidden.assign(c.maps.module_hidden.size(), c.width);
  m.selector_hidden = c.maps.selector_hidden;
  m.step_embed_dim = mlp_step_embedding(c.width);
  m.activation = c.maps.activation;
  m.selector_losses = c.maps.selector_losses;
  return m;
}

diffusion::SparseMoeDenoiserConfig moe_config(const PolicyShape& shape, const DiffusionPolicyConfig& c) {
  diffusion::SparseMoeDenoiserConfig m;
  m.horizon = c.horizon;
  m.action_dim = shape.action_size / c.horizon;
  m.state_size = shape.observation_size;
  m.cond_dim = condition_size(shape, c);
  m.num_tasks = shape.num_tasks;
  m.experts = c.experts;
  m.top_k = c.top_k;
  m.hidden.assign(static_cast<std::size_t>(c.layers), c.width);
  m.router_hidden = std::max<std::int64_t>(8, c.width / 4);
  m.step_embed_dim = mlp_step_embedding(c.width);
  return m;
}

double unet_count(const diffusion::Unet1dConfig& u) {
  const double k = static_cast<double>(u.kernel);
  const double cond = static_cast<double>(u.step_embed_dim + u.cond_dim);
  const auto conv_block = [&](double in, double out) { return in * out * k + out + 2 * out; };
  const auto residual_block = [&](double in, double out) {
    return conv_block(in, out) + conv_block(out, out) + cond * 2 * out + 2 * out + (in != out ? in * out + out : 0.0);
  };
  std::vector<double> d(u.down_dims.begin(), u.down_dims.end());
  double total = diffusion::step_embedding_parameter_count(u.step_embed_dim);
  for (std::size_t i = 0; i < d.size(); ++i) {
    total += residual_block(i == 0 ? static_cast<double>(u.action_dim) : d[i - 1], d[i]) + residual_block(d[i], d[i]);
    if (i + 1 < d.size()) total += d[i] * d[i] * 3 + d[i];
  }
  total += 2 * residual_block(d.back(), d.back());
  for (std::size_t j = d.size() - 1; j >= 1; --j)
    total +=
        residual_block(2 * d[j], d[j - 1]) + residual_block(d[j - 1], d[j - 1]) + d[j - 1] * d[j - 1] * 3 + d[j - 1];
  total += conv_block(d[0], d[0]) + d[0] * static_cast<double>(u.action_dim) + static_cast<double>(u.action_dim);
  return total;
}

double mlp_count(const diffusion::MlpDenoiserConfig& m) {
  return diffusion::step_embedding_parameter_count(m.step_embed_dim) +
         mlp_parameter_count(
             diffusion::flat_denoiser_layer_sizes(m.horizon, m.action_dim, m.step_embed_dim, m.cond_dim, m.hidden));
}

// The section's keys as a config (width as given: 0 until matched; maps.* not read).
DiffusionPolicyConfig section_config(const nlohmann::json& own) {
  DiffusionPolicyConfig c;
  c.denoiser = own.at("denoiser").get<std::string>();
  c.width = option_int(own, "width");
  c.layers = option_int(own, "layers");
  c.horizon = option_int(own, "horizon");
  c.execute = option_int(own, "execute");
  c.observations = option_int(own, "observations");
  c.training_steps = static_cast<int>(option_int(own, "training_steps"));
  c.inference_steps = static_cast<int>(option_int(own, "inference_steps"));
  c.clip = own.at("clip").get<bool>();
  c.experts = option_int(own, "experts");
  c.top_k = option_int(own, "top_k");
  c.mutual_information_weight = own.at("mutual_information_weight").get<double>();
  return c;
}

// The checks across keys, the same when the config is read (PolicyMethod::check) and when a policy is built.
void check_relations(const DiffusionPolicyConfig& c) {
  if (c.execute > c.horizon)
    throw std::invalid_argument("config diffusion_policy.execute: expected at most diffusion_policy.horizon (" +
                                std::to_string(c.horizon) + "), got " + std::to_string(c.execute));
  if (c.top_k > c.experts)
    throw std::invalid_argument("config diffusion_policy.top_k: expected at most diffusion_policy.experts (" +
                                std::to_string(c.experts) + "), got " + std::to_string(c.top_k));
  if (c.inference_steps > c.training_steps)
    throw std::invalid_argument(
        "config diffusion_policy.inference_steps: expected at most diffusion_policy.training_steps (" +
        std::to_string(c.training_steps) + "), got " + std::to_string(c.inference_steps));
  if (c.denoiser == "unet" && c.horizon % 4 != 0)
    throw std::invalid_argument(
        "config diffusion_policy.horizon: the U-Net halves the chunk twice, so it must be a multiple of 4, got " +
        std::to_string(c.horizon));
  if (c.denoiser == "unet" && c.width % kUnetGroups != 0)
    throw std::invalid_argument(
        "config diffusion_policy.width: the U-Net's group norms take 8 groups, so it must be a multiple of 8 (or "
        "0), got " +
        std::to_string(c.width));
}

void check_config(const PolicyShape& shape, const DiffusionPolicyConfig& c) {
  if (c.denoiser != "unet" && c.denoiser != "mlp" && c.denoiser != "maps" && c.denoiser != "moe")
    throw std::invalid_argument(
        "config diffusion_policy.denoiser: expected \"unet\", \"mlp\", \"maps\" or \"moe\", got \"" + c.denoiser +
        "\"");
  if (c.denoiser == "maps" && c.maps.observations != "standardized")
    throw std::invalid_argument("config maps.observations: the \"maps\" denoiser sees standardised states, got \"" +
                                c.maps.observations + "\"");
  if (c.denoiser == "maps" && c.maps.selector != "learned")
    throw std::invalid_argument("config maps.selector: the \"maps\" denoiser has a learned selector, got \"" +
                                c.maps.selector + "\"");
  if (c.horizon < 1 || shape.action_size % c.horizon != 0)
    throw std::invalid_argument("diffusion_policy: an output of " + std::to_string(shape.action_size) +
                                " is not a chunk of " + std::to_string(c.horizon) + " actions");
  if (c.execute < 1 || c.inference_steps < 1)
    throw std::invalid_argument("diffusion_policy: execute and inference_steps must be >= 1, got " +
                                std::to_string(c.execute) + " and " + std::to_string(c.inference_steps));
  check_relations(c);
}

// A row's own noise stream, seeded by the float32 bits of its condition (standardised observations and task): what
// the policy sees alone decides the draw, not the row's place in the batch, so the same states and task always start
// from the same noise.
std::uint64_t row_seed(const ag::RowMatrixD& cond, Eigen::Index row) {
  std::uint64_t h = 0x646966667573696fULL;  // "diffusio"
  for (Eigen::Index j = 0; j < cond.cols(); ++j) {
    const float v = static_cast<float>(cond(row, j));
    std::uint32_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    h = envs::splitmix64(h ^ bits);
  }
  return h;
}

}  // namespace

DiffusionPolicy::DiffusionPolicy(PolicyShape shape, const DiffusionPolicyConfig& config, ag::Generator& gen)
    : Policy("DiffusionPolicy", shape), config_(config), schedule_(config.training_steps) {
  check_config(shape, config);
  action_dim_ = shape.action_size / config.horizon;
  if (config.denoiser == "unet") {
    denoiser_ =
        register_module("denoiser", std::make_shared<diffusion::ConditionalUnet1d>(unet_config(shape, config), gen));
  } else if (config.denoiser == "mlp") {
    denoiser_ = register_module("denoiser", std::make_shared<diffusion::MlpDenoiser>(mlp_config(shape, config), gen));
  } else if (config.denoiser == "maps") {
    denoiser_ =
        register_module("denoiser", std::make_shared<diffusion::ModularDenoiser>(modular_config(shape, config), gen));
  } else {
    denoiser_ =
        register_module("denoiser", std::make_shared<diffusion::SparseMoeDenoiser>(moe_config(shape, config), gen));
  }
}

ag::Tensor DiffusionPolicy::condition(const ag::Tensor& observations, const ag::Tensor& previous_observations,
                                      const std::vector<std::int64_t>& tasks) const {
  std::vector<ag::Tensor> parts{observations};
  if (config_.observations == 2) parts.push_back(previous_observations);
  parts.push_back(ag::one_hot(tasks, shape().num_tasks, observations.dtype()));
  return ag::concat(parts, 1);
}

ag::Tensor DiffusionPolicy::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  return act_with_history(observations, observations, tasks);
}

ag::Tensor DiffusionPolicy::act_with_history(const ag::Tensor& observations, const ag::Tensor& previous_observations,
                                             const std::vector<std::int64_t>& tasks) {
  const ag::Tensor cond = condition(observations, previous_observations, tasks);
  const std::int64_t n = cond.size(0);
  const ag::RowMatrixD values = ag::to_eigen_double(cond);
  std::vector<double> noise(static_cast<std::size_t>(n * shape().action_size));
  for (std::int64_t i = 0; i < n; ++i) {
    ag::Generator gen(row_seed(values, i));
    for (std::int64_t j = 0; j < shape().action_size; ++j)
      noise[static_cast<std::size_t>(i * shape().action_size + j)] = gen.normal();
  }
  const ag::Tensor start = ag::from_vector(noise, {n, config_.horizon, action_dim_}, observations.dtype());
  const ag::Tensor chunks =
      diffusion::sample_ddim_from(denoiser(), schedule_, cond, start, config_.inference_steps, config_.clip);
  return ag::reshape(chunks, {n, shape().action_size});
}

ag::Tensor DiffusionPolicy::chunks_of(const Batch& batch) const {
  return ag::clamp(ag::reshape(batch.actions, {batch.size(), config_.horizon, action_dim_}), -1.0, 1.0);
}

LossTerms DiffusionPolicy::loss(const Batch& batch) {
  ag::Generator gen(envs::splitmix64(batch.noise_seed ^ 0x6464706dULL));  // "ddpm"
  const ag::Tensor l =
      diffusion::denoising_loss(denoiser(), schedule_, chunks_of(batch),
                                condition(batch.observations, batch.previous_observations, batch.tasks), gen);
  if (auto* moe = dynamic_cast<diffusion::SparseMoeDenoiser*>(&denoiser())) {
    const ag::Tensor mi = moe->mutual_information(moe->probabilities(batch.observations, batch.tasks), batch.tasks);
    return {l - mi * config_.mutual_information_weight, {{"denoise", l}, {"mutual_information", mi}}};
  }
  auto* modular = dynamic_cast<diffusion::ModularDenoiser*>(&denoiser());
  if (modular == nullptr) return {l, {{"denoise", l}}};
  LossTerms result;
  result.terms.emplace_back("denoise", l);
  const LossTerms selector = modular->selector_terms(batch.observations, batch.previous_observations, batch.tasks);
  result.terms.insert(result.terms.end(), selector.terms.begin(), selector.terms.end());
  result.total = l * config_.maps.bc_weight;
  if (selector.total.defined()) result.total = result.total + selector.total * config_.maps.selector_weight;
  return result;
}

ag::Tensor DiffusionPolicy::routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  if (auto* moe = dynamic_cast<diffusion::SparseMoeDenoiser*>(&denoiser())) {
    ag::NoGradGuard no_grad;
    const ag::Tensor g = moe->gates(moe->probabilities(observations, tasks), nullptr);
    return g / ag::sum(g, {1}, true);
  }
  auto* modular = dynamic_cast<diffusion::ModularDenoiser*>(&denoiser());
  return modular != nullptr ? modular->scores(observations, tasks) : ag::Tensor();
}

std::int64_t DiffusionPolicy::routed_modules() const {
  if (config_.denoiser == "maps") return config_.maps.modules;
  return config_.denoiser == "moe" ? config_.experts : 0;
}

double DiffusionPolicy::validation_loss(const Batch& validation, const DemoDataset& /*data*/) {
  ag::NoGradGuard no_grad;
  const std::int64_t n = validation.size();
  if (n == 0) throw std::invalid_argument("diffusion_policy: empty validation batch");
  const ag::Tensor chunks = chunks_of(validation);
  const ag::Tensor cond = condition(validation.observations, validation.previous_observations, validation.tasks);
  ag::Generator gen(0x76616c6964ULL);  // "valid": the same steps and noise at every validation
  constexpr std::int64_t kRows = 4096;
  double total = 0.0;
  for (std::int64_t begin = 0; begin < n; begin += kRows) {
    const std::int64_t rows = std::min(kRows, n - begin);
    const ag::Tensor l = diffusion::denoising_loss(denoiser(), schedule_, ag::narrow(chunks, 0, begin, rows),
                                                   ag::narrow(cond, 0, begin, rows), gen);
    total += l.item() * static_cast<double>(rows);
  }
  return total / static_cast<double>(n);
}

double diffusion_policy_parameter_count(const PolicyShape& shape, const DiffusionPolicyConfig& c) {
  if (c.denoiser == "unet") return unet_count(unet_config(shape, c));
  if (c.denoiser == "maps") return diffusion::modular_denoiser_parameter_count(modular_config(shape, c));
  if (c.denoiser == "moe") return diffusion::sparse_moe_denoiser_parameter_count(moe_config(shape, c));
  return mlp_count(mlp_config(shape, c));
}

namespace {

DiffusionPolicyConfig diffusion_policy_config(const PolicyShape& shape, const MethodOptions& o) {
  DiffusionPolicyConfig c = section_config(o.own);
  c.maps = o.maps;
  if (c.width != 0) return c;
  // Matched to MAPS as the study runs it: one action per step (MAPS's budget does not grow with the chunk).
  const PolicyShape step_shape{shape.observation_size, shape.action_size / c.horizon, shape.num_tasks};
  const double budget = maps_parameter_count(step_shape, o.maps);
  const std::int64_t unit = c.denoiser == "unet" ? kUnetGroups : 1;
  c.width = unit * matched_width(budget, [&](std::int64_t candidate) {
              DiffusionPolicyConfig sized = c;
              sized.width = unit * candidate;
              return diffusion_policy_parameter_count(shape, sized);
            });
  return c;
}

}  // namespace

PolicyMethod diffusion_policy_method() {
  PolicyMethod method;
  method.name = "diffusion_policy";
  method.summary =
      "Diffusion Policy (state-based): DDPM on chunks of the next actions given the last states and the task, "
      "DDIM sampling, receding-horizon execution";
  method.options = {
      io::choice_option(
          "denoiser", "unet", {"unet", "mlp", "maps", "moe"},
          "`unet`: Diffusion Policy's conditional 1-D U-Net (FiLM); `mlp`: chunk, step embedding and "
          "condition through an MLP; `maps`: MAPS's modules as denoisers, mixed by its selector on the "
          "state and task, with its selector losses (`maps.*`); `moe`: top-k expert denoisers with a router per task "
          "(after Sparse Diffusion Policy)"),
      io::integer_option("width", 0, 0, 65536,
                         "U-Net: down_dims [w, 2w, 4w] and step embedding w (the paper's low-dimensional U-Net: "
                         "256); MLP, MAPS and MoE: hidden width (MAPS: every module layer's, MoE: every expert "
                         "layer's); 0: matched to MAPS's "
                         "parameter count"),
      io::integer_option("layers", 3, 1, 64, "the MLP denoiser's and each `moe` expert's hidden layers (Mish)"),
      io::integer_option("horizon", 16, 1, 1000, "actions per chunk (the paper: 16; a multiple of 4 for the U-Net)"),
      io::integer_option("execute", 8, 1, 1000, "actions executed per chunk before sampling again (the paper: 8)"),
      io::integer_option("observations", 2, 1, 2,
                         "states the chunk is conditioned on: the current, and the "
                         "previous (the paper's n_obs_steps 2)"),
      io::integer_option("training_steps", 100, 2, 10000, "DDPM's diffusion steps (the paper: 100)"),
      io::integer_option("inference_steps", 8, 1, 10000, "DDIM's sampling steps (the paper's DDIM variant: 8)"),
      io::boolean_option("clip", true, "clip the predicted clean chunk to the action box [-1, 1] at each step"),
      io::integer_option("experts", 8, 2, 64, "`moe`: expert denoisers (Sparse Diffusion Policy: 8)"),
      io::integer_option("top_k", 2, 1, 64, "`moe`: experts each row keeps (SDP: 2; at most `experts`)"),
      io::number_option("mutual_information_weight", 5e-4, 0.0, 1e6,
                        "`moe`: weight of the negative task-expert mutual information in the loss (SDP: 5e-4)"),
  };
  method.check = [](const nlohmann::json& own) { check_relations(section_config(own)); };
  method.own_chunking = [](const nlohmann::json& own) {
    chunking::ActionChunking c;
    c.horizon = option_int(own, "horizon");
    c.execution = "open_loop";
    c.execute = option_int(own, "execute");
    c.previous_observation = option_int(own, "observations") == 2;
    return c;
  };
  method.cost_option = "denoiser";
  // Each chunk asks the denoiser inference_steps times and lasts `execute` env steps.
  method.evaluation_work = [](const nlohmann::json& own) {
    return static_cast<double>(option_int(own, "inference_steps")) / static_cast<double>(option_int(own, "execute"));
  };
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return diffusion_policy_parameter_count(shape, diffusion_policy_config(shape, o));
  };
  method.size_keys = "diffusion_policy.width and diffusion_policy.layers";
  method.sampled_bc_loss = false;
  // A DDIM sample is a deterministic map of the state, which PPO would treat as a Gaussian's mean, backpropagating
  // through every sampling step and its clipping: not the action distribution the denoiser models.
  method.not_trained_by_gail = "it samples its actions by denoising, not from a Gaussian around a mean";
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<DiffusionPolicy>(shape, diffusion_policy_config(shape, o), gen);
  };
  return method;
}

}  // namespace maps::core
