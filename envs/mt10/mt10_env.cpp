#include "envs/mt10/mt10_env.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace maps::envs::mt10 {
namespace {

constexpr const char* kObjectsMarker = "<!-- TASK_OBJECTS -->";

EnvSpec mt10_spec(std::string task, std::int64_t task_index, const MT10Options& options) {
  if (options.horizon < 1) {
    throw std::invalid_argument("task '" + task + "': horizon must be >= 1, got " + std::to_string(options.horizon));
  }
  return unit_box_spec(std::move(task), task_index, MT10Env::kObservationSize, MT10Env::kActionSize, options.horizon);
}

int require(int id, const std::string& task, const char* kind, const std::string& name) {
  if (id < 0) throw std::runtime_error("task '" + task + "': the model has no " + kind + " named '" + name + "'");
  return id;
}

}  // namespace

std::string mt10_xml(const std::string& objects_file) {
  std::string xml = read_text_file(asset_path("mt10/scene.xml"));
  const std::size_t at = xml.find(kObjectsMarker);
  if (at == std::string::npos) throw std::runtime_error("mt10/scene.xml has no " + std::string(kObjectsMarker));
  xml.replace(at, std::string(kObjectsMarker).size(), read_text_file(asset_path("mt10/" + objects_file)));
  return xml;
}

MT10Env::MT10Env(std::string task, std::int64_t task_index, const std::string& objects_file, Eigen::Vector3d hand_init,
                 MT10Options options)
    : MujocoEnv(mt10_spec(task, task_index, options), load_model_from_string(mt10_xml(objects_file), task), kFrameSkip),
      options_(options),
      hand_init_(std::move(hand_init)) {
  const mjModel* m = model();
  const int mocap_body = body_id("mocap");
  mocap_ = m->body_mocapid[mocap_body];
  if (mocap_ < 0) throw std::runtime_error("task '" + task + "': body 'mocap' is not a mocap body");
  hand_body_ = body_id("hand");
  hand_qpos_ = joint_qpos_address("hand_free");
  hand_dof_ = joint_dof_address("hand_free");
  right_finger_qpos_ = joint_qpos_address("r_close");
  left_finger_qpos_ = joint_qpos_address("l_close");
  right_tip_ = site_id("rightEndEffector");
  left_tip_ = site_id("leftEndEffector");
  goal_site_ = site_id("goal");
  if (m->nu != 2) throw std::runtime_error("task '" + task + "': the scene must have the 2 finger actuators only");
}

int MT10Env::body_id(const std::string& name) const {
  return require(mj_name2id(model(), mjOBJ_BODY, name.c_str()), spec().task, "body", name);
}

int MT10Env::site_id(const std::string& name) const {
  return require(mj_name2id(model(), mjOBJ_SITE, name.c_str()), spec().task, "site", name);
}

int MT10Env::joint_qpos_address(const std::string& name) const {
  return model()->jnt_qposadr[require(mj_name2id(model(), mjOBJ_JOINT, name.c_str()), spec().task, "joint", name)];
}

int MT10Env::joint_dof_address(const std::string& name) const {
  return model()->jnt_dofadr[require(mj_name2id(model(), mjOBJ_JOINT, name.c_str()), spec().task, "joint", name)];
}

Eigen::Vector3d MT10Env::body_position(int body) const {
  return Eigen::Map<const Eigen::Vector3d>(data()->xpos + 3 * body);
}

Eigen::Vector4d MT10Env::body_quaternion(int body) const {
  return Eigen::Map<const Eigen::Vector4d>(data()->xquat + 4 * body);
}

Eigen::Vector3d MT10Env::site_position(int site) const {
  return Eigen::Map<const Eigen::Vector3d>(data()->site_xpos + 3 * site);
}

void MT10Env::set_body_position(int body, const Eigen::Vector3d& position) {
  Eigen::Map<Eigen::Vector3d>(mutable_model()->body_pos + 3 * body) = position;
  mj_forward(model(), mutable_data());
}

double MT10Env::uniform(std::mt19937_64& rng, double low, double high) {
  return std::uniform_real_distribution<double>(low, high)(rng);
}

void MT10Env::set_goal(const Eigen::Vector3d& goal) {
  goal_ = goal;
  // The goal marker is drawn only; it moves with the goal.
  Eigen::Map<Eigen::Vector3d>(mutable_model()->site_pos + 3 * goal_site_) = goal;
}

Eigen::Vector3d MT10Env::hand_position() const { return body_position(hand_body_); }

Eigen::Vector3d MT10Env::tcp_center() const { return 0.5 * (site_position(right_tip_) + site_position(left_tip_)); }

double MT10Env::gripper_opening() const {
  return std::clamp((site_position(right_tip_) - site_position(left_tip_)).norm() / 0.1, 0.0, 1.0);
}

Eigen::VectorXd MT10Env::observe() {
  Eigen::Matrix<double, kFrameSize, 1> frame = Eigen::Matrix<double, kFrameSize, 1>::Zero();
  frame.segment<3>(0) = hand_position();
  frame[3] = gripper_opening();
  frame.segment<3>(4) = object_position();
  frame.segment<4>(7) = object_quaternion();
  Eigen::VectorXd obs(kObservationSize);
  obs.segment<kFrameSize>(0) = frame;
  obs.segment<kFrameSize>(kFrameSize) = previous_frame_;
  obs.segment<3>(2 * kFrameSize) = goal_;
  previous_frame_ = frame;
  return obs;
}

Eigen::VectorXd MT10Env::reset_model(std::mt19937_64& rng) {
  mjModel* m = mutable_model();
  mjData* d = mutable_data();
  // Meta-World drives its hand to the start for 250 physics steps; the floating hand is simply put there.
  Eigen::Map<Eigen::Vector3d>(d->mocap_pos + 3 * mocap_) = hand_init_;
  Eigen::Map<Eigen::Vector4d>(d->mocap_quat + 4 * mocap_) = Eigen::Vector4d(1, 0, 0, 0);
  Eigen::Map<Eigen::Vector3d>(d->qpos + hand_qpos_) = hand_init_;
  Eigen::Map<Eigen::Vector4d>(d->qpos + hand_qpos_ + 3) = Eigen::Vector4d(1, 0, 0, 0);
  d->qpos[right_finger_qpos_] = 0.0;
  d->qpos[left_finger_qpos_] = 0.0;
  ctrl_ << -1.0, 1.0;  // open
  std::copy(ctrl_.data(), ctrl_.data() + 2, d->ctrl);
  mj_forward(m, d);
  place_objects(rng);
  mj_forward(m, d);
  previous_frame_.setZero();
  Eigen::VectorXd obs = observe();
  // The first observation's previous-frame block repeats the current frame (Meta-World v3's convention).
  obs.segment<kFrameSize>(kFrameSize) = obs.segment<kFrameSize>(0);
  return obs;
}

StepResult MT10Env::step_clipped(const Eigen::VectorXd& action) {
  mjData* d = mutable_data();
  Eigen::Map<Eigen::Vector3d> mocap(d->mocap_pos + 3 * mocap_);
  // The delta moves the target, not the measured hand: a blocked hand is pulled ever harder (pushing, pressing).
  mocap = (mocap + kActionScale * action.head<3>()).cwiseMax(kMocapLow).cwiseMin(kMocapHigh);
  ctrl_ << action[3], -action[3];
  do_simulation(ctrl_);
  StepResult result;
  result.observation = observe();
  result.success = is_success();
  result.reward = result.success ? 1.0 : 0.0;
  result.terminated = options_.end_on_success && result.success;
  return result;
}

}  // namespace maps::envs::mt10
