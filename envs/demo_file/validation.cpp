// validate_demo_file: the checks of a DemoFile in memory, before it is written and after it is read.

#include <cmath>
#include <set>
#include <stdexcept>

#include "envs/demo_file.h"
#include "envs/demo_file/format.h"
#include "io/json_input.h"

namespace maps::envs {
namespace {

using demo_file_detail::first_non_finite;

[[noreturn]] void invalid(const std::string& what) { throw std::invalid_argument(what); }

void validate_task_names(const std::vector<std::string>& task_names) {
  std::set<std::string> names;
  for (const auto& name : task_names) {
    if (name.empty()) invalid("task_names holds an empty name");
    if (!names.insert(name).second) invalid("task_names lists '" + name + "' twice");
  }
}

void validate_extra_json(const std::string& extra_json) {
  try {
    io::parse_json(extra_json, "extra_json");
  } catch (const std::runtime_error& e) {
    invalid(e.what());
  }
}

// The demo stored at `path` (data/demo_<i>). *obs_dim and *act_dim: the first demo's widths (-1 before it), which
// every demo must have.
void validate_demo(const Demonstration& d, const std::string& path, const std::vector<std::string>& task_names,
                   Eigen::Index* obs_dim, Eigen::Index* act_dim) {
  const Eigen::Index t = d.obs.rows();
  if (t == 0) invalid(path + ": has no steps (obs has 0 rows)");
  if (d.obs.cols() == 0) invalid(path + ": obs has 0 columns");
  if (d.actions.cols() == 0) invalid(path + ": actions has 0 columns");
  if (d.actions.rows() != t)
    invalid(path + ": actions has " + std::to_string(d.actions.rows()) + " rows but obs has " + std::to_string(t));
  if (d.rewards.size() != t)
    invalid(path + ": rewards has " + std::to_string(d.rewards.size()) + " entries but obs has " + std::to_string(t) +
            " rows");
  if (static_cast<Eigen::Index>(d.dones.size()) != t)
    invalid(path + ": dones has " + std::to_string(d.dones.size()) + " entries but obs has " + std::to_string(t) +
            " rows");
  if (*obs_dim < 0) *obs_dim = d.obs.cols(), *act_dim = d.actions.cols();
  if (d.obs.cols() != *obs_dim)
    invalid(path + ": obs has " + std::to_string(d.obs.cols()) + " columns but data/demo_0's has " +
            std::to_string(*obs_dim) + " (observation size must be the same in every demo)");
  if (d.actions.cols() != *act_dim)
    invalid(path + ": actions has " + std::to_string(d.actions.cols()) + " columns but data/demo_0's has " +
            std::to_string(*act_dim) + " (action size must be the same in every demo)");
  if (auto bad = first_non_finite(d.obs, false); !bad.empty()) invalid(path + "/obs: " + bad);
  if (auto bad = first_non_finite(d.actions, false); !bad.empty()) invalid(path + "/actions: " + bad);
  if (auto bad = first_non_finite(d.rewards, true); !bad.empty()) invalid(path + "/rewards: " + bad);
  for (std::size_t s = 0; s < d.dones.size(); ++s)
    if (d.dones[s] > 1)
      invalid(path + "/dones: value " + std::to_string(d.dones[s]) + " at step " + std::to_string(s) +
              " (must be 0 or 1)");
  if (!std::isfinite(d.episode_return)) invalid(path + ": return is not finite");
  if (d.final_obs.size() != 0 && d.final_obs.size() != d.obs.cols())
    invalid(path + ": final_obs has " + std::to_string(d.final_obs.size()) + " entries but obs has " +
            std::to_string(d.obs.cols()) + " columns");
  if (!d.final_obs.allFinite()) invalid(path + ": final_obs holds a NaN or an infinite value");
  if (d.task_index < 0 || d.task_index >= static_cast<std::int64_t>(task_names.size()))
    invalid(path + ": task_index " + std::to_string(d.task_index) + " is out of range (" +
            std::to_string(task_names.size()) + " task names)");
  if (d.task != task_names[static_cast<std::size_t>(d.task_index)])
    invalid(path + ": task '" + d.task + "' differs from task_names[" + std::to_string(d.task_index) + "] = '" +
            task_names[static_cast<std::size_t>(d.task_index)] + "'");
}

void validate_mask(const std::vector<int>& mask, const std::string& name, std::size_t n_demos) {
  std::set<int> seen;
  for (int index : mask) {
    if (index < 0 || static_cast<std::size_t>(index) >= n_demos)
      invalid(name + " references demo " + std::to_string(index) + ", which does not exist (" +
              std::to_string(n_demos) + " demos)");
    if (!seen.insert(index).second) invalid(name + " lists " + demo_name(index) + " twice");
  }
}

// Each mask on its own, then no demo in both.
void validate_masks(const std::vector<int>& train, const std::vector<int>& valid, std::size_t n_demos) {
  validate_mask(train, "mask/train", n_demos);
  validate_mask(valid, "mask/valid", n_demos);
  const std::set<int> in_train(train.begin(), train.end());
  for (int index : valid)
    if (in_train.contains(index)) invalid(demo_name(index) + " is in both mask/train and mask/valid");
}

}  // namespace

void validate_demo_file(const DemoFile& f) {
  validate_task_names(f.task_names);
  validate_extra_json(f.extra_json);
  Eigen::Index obs_dim = -1, act_dim = -1;
  for (std::size_t i = 0; i < f.demos.size(); ++i)
    validate_demo(f.demos[i], "data/" + demo_name(static_cast<int>(i)), f.task_names, &obs_dim, &act_dim);
  validate_masks(f.train, f.valid, f.demos.size());
}

}  // namespace maps::envs
