#include "maps/training/run_config_fields.h"

#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>

#include "autograd/matmul_precision.h"
#include "autograd/parallel.h"

namespace maps::core {
namespace {

using Json = nlohmann::json;

// Far above any run of this library, low enough that a typo (an extra zero or three) is caught at load rather than
// hours into a run or inside an allocation.
constexpr long double kMaxDemos = 1000000;     // demonstrations per task, subsampling strides
constexpr long double kMaxSteps = 1e12;        // optimiser steps and intervals between events
constexpr long double kMaxRows = 100000000;    // states per task in a batch or a validation set
constexpr long double kMaxGailRows = 1000000;  // rows per task of a GAIL minibatch (check_gail_config's bound)
constexpr long double kMaxModules = 4096;      // MAPS's M
constexpr long double kMaxWidth = 65536;       // a layer's size (as `maps demo --hidden`)
constexpr long double kMaxWeight = 1e6;        // a loss weight

// The spec's parts an entry sets; the kind, the type's own bounds and the default come from the member it names.
struct Limits {
  long double min = -std::numeric_limits<long double>::infinity();
  long double max = std::numeric_limits<long double>::infinity();
  bool min_exclusive = false;
  std::vector<std::string> choices;
  bool non_empty = false;
  bool required = false;
  std::string type_name;  // when the docs name the type otherwise than the member's C++ type does

  Limits&& not_empty() && {
    non_empty = true;
    return std::move(*this);
  }
  Limits&& must_be_given() && {
    required = true;
    return std::move(*this);
  }
  Limits&& documented_as(std::string name) && {
    type_name = std::move(name);
    return std::move(*this);
  }
};

// [low, high]
Limits range(long double low, long double high) {
  Limits limits;
  limits.min = low;
  limits.max = high;
  return limits;
}
// (low, high]
Limits above(long double low, long double high) {
  Limits limits = range(low, high);
  limits.min_exclusive = true;
  return limits;
}
Limits one_of(std::vector<std::string> choices) {
  Limits limits;
  limits.choices = std::move(choices);
  return limits;
}
Limits any() { return Limits(); }

template <typename T>
struct Is_pair_vector : std::false_type {};
template <typename V>
struct Is_pair_vector<std::vector<std::pair<std::string, V>>> : std::true_type {
  using value_type = V;
};

// The kind, documented type name and bounds of a member of C++ type T: the value must fit the type it is stored in.
template <typename T>
void describe_type(io::Field& f) {
  using std::numeric_limits;
  auto integer = [&f](auto lowest, auto highest, const char* name) {
    f.min = std::max(f.min, static_cast<long double>(lowest));
    f.max = std::min(f.max, static_cast<long double>(highest));
    return std::string(name);
  };
  if constexpr (std::is_same_v<T, bool>) {
    f.kind = io::ValueKind::kBoolean;
    f.type_name = "bool";
  } else if constexpr (std::is_same_v<T, int>) {
    f.kind = io::ValueKind::kInteger;
    f.type_name = integer(numeric_limits<int>::min(), numeric_limits<int>::max(), "int");
  } else if constexpr (std::is_same_v<T, std::int64_t>) {
    f.kind = io::ValueKind::kInteger;
    f.type_name = integer(numeric_limits<std::int64_t>::min(), numeric_limits<std::int64_t>::max(), "int64");
  } else if constexpr (std::is_same_v<T, std::uint64_t>) {
    f.kind = io::ValueKind::kInteger;
    f.type_name = integer(0, numeric_limits<std::uint64_t>::max(), "uint64");
  } else if constexpr (std::is_same_v<T, double>) {
    f.kind = io::ValueKind::kNumber;
    f.type_name = "float";
  } else if constexpr (std::is_same_v<T, std::string>) {
    f.kind = io::ValueKind::kString;
    f.type_name = "string";
  } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
    f.kind = io::ValueKind::kStringList;
    f.type_name = "string list";
  } else if constexpr (std::is_same_v<T, std::vector<std::int64_t>>) {
    f.kind = io::ValueKind::kIntegerList;
    f.type_name = integer(numeric_limits<std::int64_t>::min(), numeric_limits<std::int64_t>::max(), "int64") + " list";
  } else if constexpr (Is_pair_vector<T>::value) {
    using V = typename Is_pair_vector<T>::value_type;
    if constexpr (std::is_same_v<V, int>) {
      f.kind = io::ValueKind::kIntegerMap;
      f.type_name = "object name: " + integer(numeric_limits<int>::min(), numeric_limits<int>::max(), "int");
    } else {
      static_assert(std::is_same_v<V, double>);
      f.kind = io::ValueKind::kNumberMap;
      f.type_name = "object name: float";
    }
  } else {
    static_assert(sizeof(T) == 0, "a run config member of a type the schema does not know");
  }
}

template <typename T>
Json to_value(const T& member) {
  if constexpr (Is_pair_vector<T>::value) {
    Json object = Json::object();
    for (const auto& [name, value] : member) object[name] = value;
    return object;
  } else {
    return Json(member);
  }
}

template <typename T>
T from_value(const Json& value) {
  if constexpr (Is_pair_vector<T>::value) {
    T out;
    for (const auto& [name, inner] : value.items())
      out.emplace_back(name, inner.template get<typename Is_pair_vector<T>::value_type>());
    return out;
  } else {
    return value.get<T>();
  }
}

class Table {
 public:
  template <typename Access>
  void add(const char* key, Access access, Limits limits, std::string meaning) {
    using T = std::remove_cvref_t<decltype(access(std::declval<RunConfig&>()))>;
    RunConfigField field;
    io::Field& f = field.spec;
    f.key = key;
    f.min = limits.min;
    f.max = limits.max;
    f.min_exclusive = limits.min_exclusive;
    f.choices = std::move(limits.choices);
    f.non_empty = limits.non_empty;
    f.required = limits.required;
    describe_type<T>(f);
    if (!limits.type_name.empty()) f.type_name = limits.type_name;
    f.meaning = std::move(meaning);
    RunConfig defaults;
    if (!f.required) f.default_value = to_value(access(defaults));
    field.get = [access](const RunConfig& c) { return to_value(access(const_cast<RunConfig&>(c))); };
    field.set = [access](RunConfig& c, const Json& value) { access(c) = from_value<T>(value); };
    fields_.push_back(std::move(field));
  }
  // The last key's choices are read at check time (they grow as plugins register entries).
  void choices_from(std::function<std::vector<std::string>()> current) {
    fields_.back().current_choices = std::move(current);
  }
  std::vector<RunConfigField> take() { return std::move(fields_); }

 private:
  std::vector<RunConfigField> fields_;
};

std::vector<RunConfigField> make_fields() {
  Table table;
  auto add = [&table](const char* key, auto access, Limits limits, std::string meaning) {
    table.add(key, access, std::move(limits), std::move(meaning));
  };
  add(
      "method", [](RunConfig & c) -> auto& { return c.method; }, one_of(policy_method_names()),
      "a registered method (`maps train --help` lists them with a line each): `maps`, `single_bc` (one MLP per "
      "task), `mt_bc` (one MLP on [state, one-hot task]), `mt_mh_bc` (a shared trunk with a head per task), "
      "`maml`, and the zoo's modular methods ([zoo.md](zoo.md)): `moore`, `paco`, `care`, `top_k_moe`, "
      "`soft_modularization`, and Diffusion Policy `diffusion_policy` (action chunks sampled by DDIM); a plugin's "
      "(`plugins`)");
  table.choices_from(policy_method_names);
  add(
      "plugins", [](RunConfig & c) -> auto& { return c.plugins; }, any(),
      "C++ plugins to load before the rest of the config is read: shared libraries whose selector losses and "
      "methods this config names ([extending.md](extending.md)); a relative path is relative to the config "
      "file's folder, and the run folder's `config.json` records the absolute path (its SHA-256 is in "
      "`provenance.json`)");
  add(
      "seed", [](RunConfig & c) -> auto& { return c.seed; }, any(),
      "draws the demonstrations, the initialisation, the batches and MAML's fine-tuning batches; runs of every "
      "method with the same seed see the same demonstrations (paired comparisons)");
  add(
      "data.file", [](RunConfig & c) -> auto& { return c.data_file; }, any().not_empty().must_be_given(),
      "the demo file (HDF5, [datasets.md](datasets.md)); a relative path is relative to the working directory "
      "of `maps train`");
  add(
      "data.demos_per_task", [](RunConfig & c) -> auto& { return c.data.demos_per_task; }, range(0, kMaxDemos),
      "training demonstrations per task, drawn without replacement from the task's `mask/train` demos (0: all "
      "of them)");
  add(
      "data.tasks", [](RunConfig & c) -> auto& { return c.data.tasks; }, any(),
      "only these tasks of the file (empty: all); the run's task ids follow the set's order among them");
  add(
      "data.holdout", [](RunConfig & c) -> auto& { return c.data.holdout; }, any(),
      "leave these tasks of the file out (a leave-one-out run that transfer later teaches them to)");
  add(
      "data.task_demos", [](RunConfig & c) -> auto& { return c.data.task_demos; },
      range(1, kMaxDemos).documented_as("object name: int"),
      "training demonstrations of particular tasks in place of `demos_per_task` (a new task's few demos), each "
      "at least 1 and only for tasks the run trains (not held out, not left out by `data.tasks`). Every task of "
      "the file is drawn in its order whatever is kept, so a task gets the same demonstrations in a run of all "
      "tasks, a leave-one-out run and a run of that task alone (same seed and counts)");
  add(
      "data.draws", [](RunConfig & c) -> auto& { return c.data.draws; }, one_of({"sequential", "per_task"}),
      "how demos and subsampling offsets are drawn: `sequential`, one stream through the file's tasks, so a "
      "task's draw also depends on the counts of the tasks before it (every run made before the key); "
      "`per_task`, a stream per task from the seed and the task's name, so its draw depends on the seed and its "
      "own count only (transfer's comparison, where the new task's count varies and the other tasks' "
      "demonstrations must not)");
  add(
      "data.subsample", [](RunConfig & c) -> auto& { return c.data.subsample; }, range(1, kMaxDemos),
      "keep every k-th state-action pair of each training demo, from an offset drawn in [0, k) (GAIL's "
      "protocol; validation states are never subsampled)");
  add(
      "data.observation_clip", [](RunConfig & c) -> auto& { return c.data.observation_clip; }, range(0, 1e6),
      "clamp the standardised observations to [-clip, clip] wherever the run standardises: training, validation, "
      "GAIL's rollouts and evaluation (0: no clamp). For dimensions the demonstrations barely vary in, such as "
      "MT10's object quaternion ([adversarial.md](adversarial.md)); RL's usual bound is 10");
  add(
      "train.steps", [](RunConfig & c) -> auto& { return c.train.steps; }, range(1, kMaxSteps),
      "optimiser steps (the paper's code: 30000; the study: 20000)");
  add(
      "train.learning_rate", [](RunConfig & c) -> auto& { return c.train.learning_rate; }, above(0, 1e3),
      "Adam's step size");
  add(
      "train.states_per_task", [](RunConfig & c) -> auto& { return c.train.states_per_task; }, range(1, kMaxRows),
      "training states per task in each batch (balanced: every task each step); the paper: 128 HalfCheetah, 32 "
      "MT10");
  add(
      "train.validate_every", [](RunConfig & c) -> auto& { return c.train.validate_every; }, range(1, kMaxSteps),
      "steps between validations (the BC loss on the validation demos)");
  add(
      "train.checkpoint_every", [](RunConfig & c) -> auto& { return c.train.checkpoint_every; }, range(1, kMaxSteps),
      "steps between writes of `last.ckpt` (what a killed run resumes from)");
  add(
      "train.validation_states_per_task", [](RunConfig & c) -> auto& { return c.train.validation_states_per_task; },
      range(0, kMaxRows),
      "validation states per task, evenly spaced through the task's validation demos (a fixed subset; 0: every "
      "validation state)");
  add(
      "train.keep_every", [](RunConfig & c) -> auto& { return c.train.keep_every; }, range(0, kMaxSteps),
      "also keep `step_<N>.ckpt` every N steps (0: never), for `maps eval --checkpoints` (the paper's "
      "best-over-checkpoints rule)");
  add(
      "train.bc_loss", [](RunConfig & c) -> auto& { return c.train.bc_loss; }, one_of({"mean", "sampled"}),
      "`mean`: squared error of the mean action; `sampled`: of a Gaussian sample with a learned "
      "state-independent log-std (the paper's code; not for `maml`)");
  add(
      "train.freeze", [](RunConfig & c) -> auto& { return c.train.freeze; }, any(),
      "parameters whose name starts with one of these are not trained and stay bit for bit as they started "
      "(transfer: `[\"modules\"]`, `[\"modules\", \"head\"]`); a prefix that names no parameter is an error "
      "listing the names");
  add(
      "train.lr_scale", [](RunConfig & c) -> auto& { return c.train.lr_scale; },
      range(0, 1e6).documented_as("object prefix: float"),
      "learning-rate factors by parameter-name prefix (transfer with fine-tuned modules: `{\"modules\": 0.1}`; 0: "
      "not moved, as if frozen); refused for a prefix that overlaps a `train.freeze` one");
  add(
      "train.validation_tasks", [](RunConfig & c) -> auto& { return c.train.validation_tasks; }, any(),
      "judge checkpoints (the best validation loss) on these tasks' validation states only; empty: every "
      "task's. Transfer's comparison judges a multi-task run taught a new task on the new task, as it judges "
      "the runs of that task alone");
  add(
      "train.flush_denormal", [](RunConfig & c) -> auto& { return c.train.flush_denormal; }, any(),
      "training flushes denormal floats to zero (3-6x faster steps once MAPS's selector sharpens; "
      "docs/performance.md, \"Denormals\"); `false` computes with IEEE denormals, bit for bit as runs made "
      "before the key existed");
  add(
      "train.precision", [](RunConfig & c) -> auto& { return c.train.precision; }, one_of(ag::matmul_precision_names()),
      "the training steps' matrix products: `float32`, or `bf16` (operands rounded to bfloat16, sums, parameters, "
      "Adam's state, losses and validation in float32; 1.4x faster steps where the CPU has AVX512-BF16, refused "
      "by name on one without; docs/performance.md, \"bfloat16\")");
  add(
      "train.optimizer", [](RunConfig & c) -> auto& { return c.train.optimizer; }, one_of({"joint", "alternating"}),
      "`joint`: one Adam step on every parameter per batch; `alternating`: the paper's code's (`train.py`): the "
      "selector's parameters step first, then the loss is computed again with the stepped selector (a fresh "
      "sampled-BC draw) and the modules and head step (MAPS with a learned selector only)");
  add(
      "train.adam_eps", [](RunConfig & c) -> auto& { return c.train.adam_eps; }, range(1e-30, 1),
      "Adam's epsilon (torch's default; the paper's code 1e-5); added in float32, where a smaller value rounds to 0 "
      "and a step divides by zero");
  add(
      "train.ema_power", [](RunConfig & c) -> auto& { return c.train.ema_power; }, range(0, 10),
      "an exponential moving average of the parameters, as Diffusion Policy evaluates (0.75 there): after update n "
      "the average moves by decay 1 - (n - 1)^-power (0 for the first two updates), capped at `train.ema_max_decay`; "
      "validation judges the average, and best.ckpt and step_<N>.ckpt keep it. 0: no average (the default)");
  add(
      "train.ema_max_decay", [](RunConfig & c) -> auto& { return c.train.ema_max_decay; }, range(0, 0.999999),
      "the cap on the average's decay (Diffusion Policy's 0.9999)");
  add(
      "maps.modules", [](RunConfig & c) -> auto& { return c.maps.modules; }, range(1, kMaxModules),
      "M, the proto-policy modules");
  add(
      "maps.module_hidden", [](RunConfig & c) -> auto& { return c.maps.module_hidden; },
      range(1, kMaxWidth).not_empty(), "each module's layer sizes; the last is its feature size");
  add(
      "maps.selector_hidden", [](RunConfig & c) -> auto& { return c.maps.selector_hidden; }, range(1, kMaxWidth),
      "the selector G(s, k)'s hidden sizes ([S + K] -> ... -> M, softmax)");
  add(
      "maps.activation", [](RunConfig & c) -> auto& { return c.maps.activation; },
      one_of({"tanh", "relu", "sigmoid", "identity"}),
      "after every module layer and in the selector's hidden layers: `tanh`, `relu`, `sigmoid`, `identity`");
  add(
      "maps.bc_weight", [](RunConfig & c) -> auto& { return c.maps.bc_weight; }, range(0, kMaxWeight),
      "weight of the BC loss in the total (0: the selector losses alone)");
  add(
      "maps.selector_weight", [](RunConfig & c) -> auto& { return c.maps.selector_weight; }, range(0, kMaxWeight),
      "weight of the weighted selector losses in the total (0: none of them)");
  add(
      "maps.selector_losses", [](RunConfig & c) -> auto& { return c.maps.selector_losses; }, range(0, kMaxWeight),
      "the selector losses and their weights (lambda); the paper's MT10 weights are `{\"share\": 1, "
      "\"explore\": 0.1, \"sparse\": 0.5, \"smooth\": 1}`; a weight of 0 is the ablation; an object given "
      "replaces the whole default (name every loss you want)");
  add(
      "maps.selector", [](RunConfig & c) -> auto& { return c.maps.selector; }, one_of({"learned", "uniform", "task"}),
      "`learned`: G(s, k); `uniform`: every score 1/M, no selector losses (the control; the policy then does "
      "not see the task, which reaches MAPS through the selector alone); `task`: G(k), the selector with its "
      "state input zeroed, one fixed mixture of modules per task (the control for whether routing needs the "
      "state; the first layer's state columns stay, unused)");
  add(
      "maps.observations", [](RunConfig & c) -> auto& { return c.maps.observations; },
      one_of({"standardized", "raw_clipped"}),
      "`standardized`: modules and selector see standardised observations; `raw_clipped`: the paper's code's "
      "inputs (modules: raw clipped to [-5, 5]; selector: raw)");
  add(
      "maml.inner_lr", [](RunConfig & c) -> auto& { return c.maml.inner_lr; }, range(0, 1e3),
      "inner-loop and fine-tuning SGD step size (0: no adaptation, theta itself for every task: the control "
      "without MAML's inner step)");
  add(
      "maml.inner_steps", [](RunConfig & c) -> auto& { return c.maml.inner_steps; }, range(1, 1000),
      "SGD steps on the support rows per meta-training task");
  add(
      "maml.first_order", [](RunConfig & c) -> auto& { return c.maml.first_order; }, any(),
      "drop the second-order terms (first-order MAML)");
  add(
      "maml.query_per_task", [](RunConfig & c) -> auto& { return c.maml.query_per_task; }, range(1, kMaxRows),
      "query rows per task in each meta-batch (the paper: 160 HalfCheetah, 40 MT10)");
  add(
      "maml.finetune_steps", [](RunConfig & c) -> auto& { return c.maml.finetune_steps; }, range(0, 1000000),
      "the most SGD steps per task before evaluation (0: evaluated unadapted)");
  add(
      "maml.validate", [](RunConfig & c) -> auto& { return c.maml.validate; }, one_of({"unadapted", "adapted"}),
      "what chooses the checkpoint: `unadapted` (theta's validation error) or `adapted` (the fine-tuned "
      "policies')");
  add(
      "baselines.hidden", [](RunConfig & c) -> auto& { return c.baseline_hidden; }, range(1, kMaxWidth).not_empty(),
      "the MLP of Single BC, MT-BC, MT-MH-BC and MAML (refused for the methods it does not size: `maps`, whose "
      "sizes are `maps.*_hidden`, and the zoo's, whose sizes are in their own sections)");
  add(
      "chunking.horizon", [](RunConfig & c) -> auto& { return c.chunking.horizon; }, range(1, 1000),
      "actions each query predicts, the step's and the H - 1 after it (1: one per step); the method's output grows "
      "to H x the action size and it is trained on the demonstrations' chunks (the last action repeated past a "
      "demonstration's end) ([zoo.md](zoo.md), action chunking); a method with chunks of its own "
      "(`diffusion_policy`) sets them in its section instead");
  add(
      "chunking.execution", [](RunConfig & c) -> auto& { return c.chunking.execution; },
      one_of(chunking::execution_names()),
      "`ensemble`: query every step and average every chunk covering the step with ACT's weights exp(-m i), i = 0 "
      "the oldest; `open_loop`: take `chunking.execute` actions of a chunk, then query again");
  add(
      "chunking.execute", [](RunConfig & c) -> auto& { return c.chunking.execute; }, range(1, 1000),
      "`open_loop`: actions taken from each chunk (at most `chunking.horizon`)");
  add(
      "chunking.ensemble_decay", [](RunConfig & c) -> auto& { return c.chunking.ensemble_decay; }, range(0, 1e3),
      "`ensemble`: m in the weights exp(-m i) (ACT: 0.01)");
  add(
      "eval.episodes", [](RunConfig & c) -> auto& { return c.eval_episodes; }, range(1, 1000000),
      "`maps eval`'s episodes per task (held-out seeds from 4,000,000,000)");
  add(
      "eval.threads", [](RunConfig & c) -> auto& { return c.eval_threads; }, range(0, ag::kMaxThreads),
      "`maps eval`'s threads (0: one per core; at most 256)");
  add(
      "eval.tasks", [](RunConfig & c) -> auto& { return c.eval_tasks; }, any(),
      "`maps eval` scores only these of the run's tasks (empty: all); a suite's new-task cells score the new "
      "task alone");
  add(
      "init.run", [](RunConfig & c) -> auto& { return c.init_run; }, any(),
      "start from this run folder's parameters (a relative path is relative to the run folder itself: a suite's "
      "transfer cell names its source `../<cell>`) (transfer; `maps transfer` writes it): parameters of the "
      "same name are copied, a [state, task] input layer gets each task's column by name (a new task: the mean "
      "of the known ones), and the run standardises observations with that checkpoint's statistics; the "
      "starting parameters are validated as step 0 and are best.ckpt's if no trained step beats them (best step "
      "0: training on the new data only made the policy worse on validation)");
  add(
      "init.checkpoint", [](RunConfig & c) -> auto& { return c.init_checkpoint; }, any().not_empty(),
      "the checkpoint of `init.run` to start from");
  add(
      "imitation", [](RunConfig & c) -> auto& { return c.imitation; }, one_of({"bc", "gail"}),
      "`bc`: behaviour cloning on the demonstrations (the study's); `gail`: adversarial imitation, the policy "
      "trained by PPO on a discriminator's reward in the envs ([adversarial.md](adversarial.md)), set by `gail.*`, for "
      "every method but `maml` and `diffusion_policy` (not Gaussian policies); "
      "`train.*` then applies only through `train.validation_states_per_task` and the BC term's loss "
      "(`gail.bc_weight`)");
  add(
      "gail.env_steps_per_task", [](RunConfig & c) -> auto& { return c.gail.env_steps_per_task; }, range(1, 1e10),
      "env steps per task the run takes; PPO's learning rate anneals to 0 there");
  add(
      "gail.rollout_episodes", [](RunConfig & c) -> auto& { return c.gail.rollout_episodes; }, range(1, 1000),
      "episodes per task per iteration, every task's stepped in lockstep with one policy call a step");
  add(
      "gail.threads", [](RunConfig & c) -> auto& { return c.gail.threads; }, range(1, ag::kMaxThreads),
      "threads stepping the envs and running ops (the rollouts' threads change no result; past 2^18 multiply-adds "
      "the ops split gradient sums by thread, as any run's --threads)");
  add(
      "gail.epochs", [](RunConfig & c) -> auto& { return c.gail.epochs; }, range(1, 1000),
      "PPO epochs over each iteration's rollout");
  add(
      "gail.minibatch_per_task", [](RunConfig & c) -> auto& { return c.gail.minibatch_per_task; },
      range(1, kMaxGailRows), "rows of every task in a PPO minibatch (balanced, as MAPS's selector losses expect)");
  add(
      "gail.clip", [](RunConfig & c) -> auto& { return c.gail.clip; }, above(0, 1), "PPO's clip range");
  add(
      "gail.gamma", [](RunConfig & c) -> auto& { return c.gail.gamma; }, range(0, 1), "discount");
  add(
      "gail.gae_lambda", [](RunConfig & c) -> auto& { return c.gail.gae_lambda; }, range(0, 1), "GAE's lambda");
  add(
      "gail.learning_rate", [](RunConfig & c) -> auto& { return c.gail.learning_rate; }, above(0, 1),
      "Adam's step size for the policy, its log std and the critic");
  add(
      "gail.adam_eps", [](RunConfig & c) -> auto& { return c.gail.adam_eps; }, above(0, 1), "that Adam's epsilon");
  add(
      "gail.anneal_learning_rate", [](RunConfig & c) -> auto& { return c.gail.anneal_learning_rate; }, any(),
      "anneal the learning rate linearly to 0 over `gail.env_steps_per_task`");
  add(
      "gail.value_coef", [](RunConfig & c) -> auto& { return c.gail.value_coef; }, range(0, 1e3),
      "the critic's squared error's weight in the PPO loss");
  add(
      "gail.entropy_coef", [](RunConfig & c) -> auto& { return c.gail.entropy_coef; }, range(0, 1),
      "the Gaussian's entropy bonus");
  add(
      "gail.max_grad_norm", [](RunConfig & c) -> auto& { return c.gail.max_grad_norm; }, above(0, 1e6),
      "the gradient's 2-norm clip over the policy, log std and critic together");
  add(
      "gail.critic_hidden", [](RunConfig & c) -> auto& { return c.gail.critic_hidden; }, range(1, 4096).not_empty(),
      "the critic V(s, task): a tanh MLP on [s, one_hot(task)]");
  add(
      "gail.initial_log_std", [](RunConfig & c) -> auto& { return c.gail.initial_log_std; }, range(-10, 2),
      "the Gaussian's state-independent log std at the start, per action");
  add(
      "gail.normalize_reward", [](RunConfig & c) -> auto& { return c.gail.normalize_reward; }, any(),
      "divide each task's rewards by the running std of its discounted return");
  add(
      "gail.reward", [](RunConfig & c) -> auto& { return c.gail.reward; }, one_of(adversarial::gail_reward_kinds()),
      "the policy's reward from the discriminator's logit l: `gail` -log(1 - D) = softplus(l), `log_d` log D, "
      "`logit` l");
  add(
      "gail.discriminator_hidden", [](RunConfig & c) -> auto& { return c.gail.discriminator.hidden; },
      range(1, 4096).not_empty(), "the discriminator's hidden layers");
  add(
      "gail.discriminator_activation", [](RunConfig & c) -> auto& { return c.gail.discriminator.activation; },
      one_of({"tanh", "relu"}), "its activation");
  add(
      "gail.discriminator_conditioning", [](RunConfig & c) -> auto& { return c.gail.discriminator.conditioning; },
      one_of({"input", "heads"}),
      "`input`: one_hot(task) beside (s, a), one logit; `heads`: one logit per task from a shared trunk");
  add(
      "gail.gradient_penalty", [](RunConfig & c) -> auto& { return c.gail.discriminator_loss.gradient_penalty; },
      range(0, 1e4), "lambda of E[(||grad D|| - 1)^2] between demonstration and policy pairs (0: off)");
  add(
      "gail.entropy_bonus", [](RunConfig & c) -> auto& { return c.gail.discriminator_loss.entropy_bonus; }, range(0, 1),
      "the discriminator's Bernoulli entropy bonus (0: off)");
  add(
      "gail.discriminator_learning_rate", [](RunConfig & c) -> auto& { return c.gail.discriminator_learning_rate; },
      above(0, 1), "the discriminator's Adam step size");
  add(
      "gail.discriminator_updates", [](RunConfig & c) -> auto& { return c.gail.discriminator_updates; },
      range(0, 100000), "discriminator steps per iteration");
  add(
      "gail.discriminator_batch_per_task", [](RunConfig & c) -> auto& { return c.gail.discriminator_batch_per_task; },
      range(1, kMaxGailRows), "demonstration pairs per task in a discriminator step, and as many of the policy's");
  add(
      "gail.discriminator_warmup_iterations",
      [](RunConfig & c) -> auto& { return c.gail.discriminator_warmup_iterations; }, range(0, 1000000),
      "the first iterations, which take `gail.discriminator_warmup_updates` discriminator steps");
  add(
      "gail.discriminator_warmup_updates", [](RunConfig & c) -> auto& { return c.gail.discriminator_warmup_updates; },
      range(0, 100000), "discriminator steps in each warm-up iteration");
  add(
      "gail.bc_weight", [](RunConfig & c) -> auto& { return c.gail.bc_weight; }, range(0, kMaxWeight),
      "weight of a BC term (the method's own BC loss with its regularisers) beside the adversarial one (0: off)");
  add(
      "gail.bc_states_per_task", [](RunConfig & c) -> auto& { return c.gail.bc_states_per_task; },
      range(1, kMaxGailRows), "demonstration states per task in that term's batch");
  add(
      "gail.checkpoint", [](RunConfig & c) -> auto& { return c.gail.checkpoint; }, one_of({"last", "validation"}),
      "best.ckpt: the policy after the `last` iteration, or the iteration of lowest `validation` BC loss");
  add(
      "gail.checkpoint_every", [](RunConfig & c) -> auto& { return c.gail.checkpoint_every; }, range(1, 1000000),
      "iterations between writes of last.ckpt (and at the end)");
  return table.take();
}

}  // namespace

const std::vector<RunConfigField>& run_config_fields() {
  static const std::vector<RunConfigField> fields = make_fields();
  return fields;
}

io::Field RunConfigField::current_spec() const {
  if (!current_choices) return spec;
  io::Field now = spec;
  now.choices = current_choices();
  return now;
}

std::vector<io::Field> run_config_schema() {
  std::vector<io::Field> schema;
  for (const RunConfigField& field : run_config_fields()) {
    schema.push_back(field.current_spec());
    if (field.spec.key != "baselines.hidden") continue;
    for (const PolicyMethod& method : policy_methods())
      for (io::Field option : method.options) {
        option.key = method.name + "." + option.key;
        schema.push_back(std::move(option));
      }
  }
  return schema;
}

}  // namespace maps::core
