#pragma once

#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "maps/adversarial/gail_config.h"
#include "maps/data/demo_dataset.h"
#include "maps/policies/baseline_util.h"
#include "maps/policies/maml.h"
#include "maps/policies/maps_policy.h"
#include "maps/policies/policy.h"
#include "maps/policies/policy_registry.h"
#include "maps/training/run_files.h"
#include "maps/training/trainer.h"

// One run's configuration as JSON (`maps train --config`), every key optional but "method" and "data.file":
//
//   {"method": "maps",                       // a name of policy_registry.h (maps, single_bc, mt_bc, ...)
//    "plugins": ["libmine.so"],               // C++ plugins the tool loads first (docs/extending.md)
//    "seed": 0,                              // data draw, initialisation and batches all derive from it
//    "data": {"file": "data/gravity.h5", "demos_per_task": 5, "subsample": 20,
//             "draws": "sequential"},                   // or "per_task" (DataConfig::draws)
//    "train": {"steps": 30000, "learning_rate": 3e-4, "states_per_task": 128, "validate_every": 1000,
//              "checkpoint_every": 1000, "validation_states_per_task": 2000, "keep_every": 0,
//              "bc_loss": "mean",                       // or "sampled" (the paper's code; not for maml)
//              "validation_tasks": [],                  // judge checkpoints on these tasks only (empty: all)
//              "optimizer": "joint", "adam_eps": 1e-8},  // or "alternating": the paper's code's selector-first step
//    "maps": {"modules": 10, "activation": "tanh", "selector": "learned",   // or "uniform" (scores 1/M), "task" (G(k))
//             "selector_losses": {"share": 1, "explore": 0.5, "sparse": 0.001, "smooth": 1}},
//    "maml": {"inner_lr": 0.01, "inner_steps": 1, "first_order": false, "query_per_task": 160, "finetune_steps": 10,
//             "validate": "unadapted"},              // or "adapted": checkpoints judged after fine-tuning
//    "baselines": {"hidden": [128, 128, 128]},  // the MLP of Single BC, MT-BC, MT-MH-BC and MAML
//    "chunking": {"horizon": 1, "execution": "ensemble", "execute": 1, "ensemble_decay": 0.01},  // action chunks
//    "eval": {"episodes": 100, "threads": 0, "tasks": []},   // tasks: evaluate only these of the run's
//    "init": {"run": "", "checkpoint": "best.ckpt"},        // transfer: start from that run's parameters
//    "imitation": "bc",                       // or "gail": adversarial imitation, set by "gail": {...}
//    (docs/adversarial.md)
//    "<method>": {...}}                       // a registered method's own section (its keys and defaults there)
//
// An unknown key is an error naming it (a typo must not silently run the default).
namespace maps::core {

struct RunConfig {
  std::string method = "maps";
  // Shared libraries to load before the config is read (their losses and methods; the tool loads them:
  // experiments/process/plugins.h). The library only carries the list.
  std::vector<std::string> plugins;
  std::uint64_t seed = 0;
  std::string data_file;
  DataConfig data;
  TrainConfig train;
  MAPSConfig maps;
  MAMLConfig maml;
  std::vector<std::int64_t> baseline_hidden = detail::default_hidden_sizes();
  // The method's own section ("moore": {...}) with every default filled in; {} for a method without one.
  nlohmann::json method_options = nlohmann::json::object();
  // Action chunks for a method that predicts one action per step (chunking.*); a method with chunks of its own
  // (PolicyMethod::own_chunking) leaves it at its default and sets them in its section.
  chunking::ActionChunking chunking;
  int eval_episodes = 100;
  int eval_threads = 0;
  std::vector<std::string> eval_tasks;  // `maps eval` scores only these of the run's tasks (empty: all)
  // Start from another run's parameters (transfer, docs/transfer.md): the folder and its checkpoint. The run then
  // also standardises observations with that checkpoint's statistics, as its modules were trained to see them.
  std::string init_run;
  std::string init_checkpoint = run_files::kBestCheckpoint;
  // "bc": behaviour cloning on the demonstrations (train_policy, the study's). "gail": adversarial imitation with
  // interaction in the envs (maps/adversarial/gail_trainer.h), set by the "gail" section; train.* other than
  // validation_states_per_task and the BC loss's settings do not apply then.
  std::string imitation = "bc";
  adversarial::GailConfig gail;
};

RunConfig parse_run_config(const nlohmann::json& json);
// Every field, defaults included: what a run folder records.
nlohmann::json to_json(const RunConfig& config);

// The GAIL trainer's settings of a run: `gail` with the validation subset of `train` (the one train key GAIL reads).
adversarial::GailConfig gail_config_of(const RunConfig& config);

// The run config that teaches `task` from `demos` of its demonstrations to a MAPS run that never saw it (`maps
// transfer` and the suite's transfer cells; the caller sets "init"): the task alone, the given parameter prefixes
// frozen, the modules' learning rate scaled (1: not), judged and evaluated on the task. A source that itself
// started from another run (init.run) is refused: its modules may have seen the task. The explore term is
// switched off: it asks a batch to use every module equally, which over the source's many tasks balanced them
// and over one task's states alone would push the new task onto modules that other tasks own.
nlohmann::json transfer_request(nlohmann::json source_request, const std::string& task, int demos,
                                const std::vector<std::string>& freeze, double module_lr_scale);

// How the run's policy predicts and executes actions: the method's own chunks, else chunking.*.
chunking::ActionChunking action_chunking(const RunConfig& config);
// The method's policy for the data's shapes (one step's action size; make_policy widens the output for chunks),
// initialised from the run's seed.
std::shared_ptr<Policy> make_policy(const RunConfig& config, const PolicyShape& shape);
// The method's parameter count for these shapes, and MAPS's under the same config (the zoo's budget; with
// chunking.* MAPS's output is as wide, a method's own chunks leave it at one action).
double policy_parameter_count(const RunConfig& config, const PolicyShape& shape);
double maps_parameter_count(const RunConfig& config, const PolicyShape& shape);

}  // namespace maps::core
