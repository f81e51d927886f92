#include "envs/mujoco_env.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "envs/source_folders.h"

namespace maps::envs {
namespace {

constexpr int kErrorSize = 1000;

struct VfsDeleter {
  void operator()(mjVFS* vfs) const {
    mj_deleteVFS(vfs);
    delete vfs;
  }
};

std::string trimmed(const char* text) {
  std::string s(text);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  return s;
}

}  // namespace

MjModelPtr load_model_from_string(const std::string& xml, const std::string& name) {
  // mjVFS holds fixed arrays of a few MB: keep it off the stack.
  std::unique_ptr<mjVFS, VfsDeleter> vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  const char* file_name = "model.xml";  // the name inside the in-memory file system
  if (mj_makeEmptyFileVFS(vfs.get(), file_name, static_cast<int>(xml.size())) != 0) {
    throw std::runtime_error("MuJoCo: cannot create an in-memory file for the model of '" + name + "'");
  }
  const int index = mj_findFileVFS(vfs.get(), file_name);
  std::memcpy(vfs->filedata[index], xml.data(), xml.size());
  char error[kErrorSize] = "";
  mjModel* model = mj_loadXML(file_name, vfs.get(), error, kErrorSize);
  if (model == nullptr) {
    throw std::runtime_error("MuJoCo could not compile the model of '" + name + "': " + trimmed(error));
  }
  return MjModelPtr(model);
}

MjModelPtr load_model_from_file(const std::filesystem::path& path) {
  if (!std::filesystem::is_regular_file(path)) {
    throw std::runtime_error("MuJoCo model file '" + path.string() + "' does not exist");
  }
  char error[kErrorSize] = "";
  mjModel* model = mj_loadXML(path.c_str(), nullptr, error, kErrorSize);
  if (model == nullptr) {
    throw std::runtime_error("MuJoCo could not compile '" + path.string() + "': " + trimmed(error));
  }
  return MjModelPtr(model);
}

std::filesystem::path assets_dir() { return find_envs_folder("assets", "MAPS_ASSETS_DIR"); }

std::string mujoco_env_version() { return std::string("maps-envs 1, MuJoCo ") + mj_versionString(); }

std::filesystem::path asset_path(const std::string& file_name) {
  const auto path = assets_dir() / file_name;
  if (!std::filesystem::is_regular_file(path)) {
    throw std::runtime_error("asset '" + file_name + "' not found: '" + path.string() + "' does not exist");
  }
  return path;
}

std::string read_text_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open '" + path.string() + "' for reading");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw std::runtime_error("error while reading '" + path.string() + "'");
  return text.str();
}

MujocoEnv::MujocoEnv(EnvSpec spec, MjModelPtr model, int frame_skip)
    : spec_(std::move(spec)), model_(std::move(model)), frame_skip_(frame_skip) {
  if (!model_) throw std::invalid_argument("MujocoEnv '" + spec_.task + "': no model");
  if (frame_skip_ < 1) {
    throw std::invalid_argument("MujocoEnv '" + spec_.task + "': frame_skip must be >= 1, got " +
                                std::to_string(frame_skip_));
  }
  // The action need not map one to one onto actuators (MT10 moves a mocap body with 3 of its 4 entries);
  // do_simulation() checks the control against the model.
  if (spec_.action_size < 1 || spec_.action_low.size() != spec_.action_size ||
      spec_.action_high.size() != spec_.action_size) {
    throw std::invalid_argument("MujocoEnv '" + spec_.task + "': action size " + std::to_string(spec_.action_size) +
                                " must be >= 1 and match both bounds' sizes");
  }
  data_.reset(mj_makeData(model_.get()));
  if (!data_) throw std::runtime_error("MujocoEnv '" + spec_.task + "': mj_makeData failed");
  clipped_.resize(spec_.action_size);
}

Eigen::VectorXd MujocoEnv::reset(std::uint64_t seed) {
  mj_resetData(model_.get(), data_.get());
  std::mt19937_64 rng(seed);
  Eigen::VectorXd observation = reset_model(rng);
  elapsed_steps_ = 0;
  needs_reset_ = false;
  return observation;
}

StepResult MujocoEnv::step(const Eigen::VectorXd& action) {
  if (action.size() != spec_.action_size) {
    throw std::invalid_argument("task '" + spec_.task + "': action has " + std::to_string(action.size()) +
                                " entries, expected " + std::to_string(spec_.action_size));
  }
  for (Eigen::Index i = 0; i < action.size(); ++i) {
    if (std::isnan(action[i])) {
      throw std::invalid_argument("task '" + spec_.task + "': action entry " + std::to_string(i) + " is NaN");
    }
  }
  if (needs_reset_) {
    throw std::logic_error("task '" + spec_.task + "': step() before reset() or after the episode ended (" +
                           std::to_string(elapsed_steps_) + " steps); call reset()");
  }
  clipped_ = action.cwiseMax(spec_.action_low).cwiseMin(spec_.action_high);
  StepResult result = step_clipped(clipped_);
  if (const double weight = control_cost_weight(); weight > 0.0)
    result.unclipped_control_cost = weight * (action.squaredNorm() - clipped_.squaredNorm());
  check_capacity();
  ++elapsed_steps_;
  if (spec_.horizon > 0 && elapsed_steps_ >= spec_.horizon) result.truncated = true;
  if (result.done()) needs_reset_ = true;
  return result;
}

void MujocoEnv::check_capacity() const {
  // MuJoCo drops what does not fit and only counts a warning: the physics would silently differ.
  const int contacts = data_->warning[mjWARN_CONTACTFULL].number, rows = data_->warning[mjWARN_CNSTRFULL].number;
  if (contacts == 0 && rows == 0) return;
  throw std::runtime_error("task '" + spec_.task + "': MuJoCo ran out of room for " +
                           (contacts > 0 ? "contacts (nconmax " + std::to_string(model_->nconmax) + ")"
                                         : "constraint rows (njmax " + std::to_string(model_->njmax) + ")") +
                           " at step " + std::to_string(elapsed_steps_ + 1) +
                           "; raise <size> in the task's model, or the physics would silently drop them");
}

void MujocoEnv::set_state(const Eigen::VectorXd& qpos, const Eigen::VectorXd& qvel) {
  if (qpos.size() != model_->nq || qvel.size() != model_->nv) {
    throw std::invalid_argument("task '" + spec_.task + "': set_state takes qpos of size " +
                                std::to_string(model_->nq) + " and qvel of size " + std::to_string(model_->nv) +
                                ", got " + std::to_string(qpos.size()) + " and " + std::to_string(qvel.size()));
  }
  std::copy(qpos.data(), qpos.data() + qpos.size(), data_->qpos);
  std::copy(qvel.data(), qvel.data() + qvel.size(), data_->qvel);
  mj_forward(model_.get(), data_.get());
}

void MujocoEnv::do_simulation(const Eigen::VectorXd& ctrl) {
  if (ctrl.size() != model_->nu) {
    throw std::invalid_argument("task '" + spec_.task + "': control has " + std::to_string(ctrl.size()) +
                                " entries, the model has " + std::to_string(model_->nu) + " actuators");
  }
  std::copy(ctrl.data(), ctrl.data() + model_->nu, data_->ctrl);
  for (int i = 0; i < frame_skip_; ++i) mj_step(model_.get(), data_.get());
}

}  // namespace maps::envs
