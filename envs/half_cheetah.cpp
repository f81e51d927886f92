#include "envs/half_cheetah.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace maps::envs {
namespace {

// Position of the value of attribute `attribute` inside the tag text [tag_begin, tag_end), or
// npos. The key must follow whitespace, so `size` does not match the tail of another name.
std::size_t find_attribute(const std::string& xml, std::size_t tag_begin, std::size_t tag_end,
                           const std::string& attribute) {
  const std::string key = attribute + "=\"";
  for (std::size_t at = xml.find(key, tag_begin); at != std::string::npos && at < tag_end; at = xml.find(key, at + 1)) {
    if (std::isspace(static_cast<unsigned char>(xml[at - 1]))) return at + key.size();
  }
  return std::string::npos;
}

std::string format_number(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

// Multiplies every number of the `size` attribute of the <geom> named `geom` by `scale`.
std::string scale_geom_size(std::string xml, const std::string& geom, double scale) {
  std::size_t tag_begin = 0;
  while ((tag_begin = xml.find("<geom", tag_begin)) != std::string::npos) {
    const std::size_t tag_end = xml.find('>', tag_begin);
    if (tag_end == std::string::npos) break;
    const std::size_t name_at = find_attribute(xml, tag_begin, tag_end, "name");
    if (name_at != std::string::npos && xml.compare(name_at, geom.size() + 1, geom + "\"") == 0) {
      const std::size_t size_at = find_attribute(xml, tag_begin, tag_end, "size");
      const std::size_t size_end = size_at == std::string::npos ? size_at : xml.find('"', size_at);
      if (size_end == std::string::npos || size_end > tag_end) {
        throw std::runtime_error("half_cheetah.xml: geom '" + geom + "' has no size attribute");
      }
      std::istringstream numbers(xml.substr(size_at, size_end - size_at));
      std::string scaled;
      double value = 0.0;
      while (numbers >> value) {
        if (!scaled.empty()) scaled += ' ';
        scaled += format_number(value * scale);
      }
      if (scaled.empty() || !numbers.eof()) {
        throw std::runtime_error("half_cheetah.xml: cannot parse the size of geom '" + geom + "'");
      }
      xml.replace(size_at, size_end - size_at, scaled);
      return xml;
    }
    tag_begin = tag_end;
  }
  throw std::invalid_argument("half_cheetah.xml has no geom named '" + geom + "'");
}

EnvSpec half_cheetah_spec(std::string task, std::int64_t task_index) {
  return unit_box_spec(std::move(task), task_index, HalfCheetahEnv::kObservationSize, HalfCheetahEnv::kActionSize,
                       HalfCheetahEnv::kHorizon);
}

MjModelPtr compile_variant(const std::string& task, const HalfCheetahVariant& variant) {
  if (!(variant.gravity_scale >= 0.0) || !std::isfinite(variant.gravity_scale)) {
    throw std::invalid_argument("task '" + task + "': gravity scale must be finite and >= 0");
  }
  for (const auto& [geom, scale] : variant.geom_size_scale) {
    if (!(scale > 0.0) || !std::isfinite(scale)) {
      throw std::invalid_argument("task '" + task + "': size scale of geom '" + geom + "' must be finite and > 0");
    }
  }
  MjModelPtr model = load_model_from_string(half_cheetah_xml(variant), task);
  // Only z changes, as in gym-extensions; no recompile is needed for gravity.
  model->opt.gravity[2] = -HalfCheetahEnv::kStandardGravity * variant.gravity_scale;
  return model;
}

}  // namespace

std::string half_cheetah_xml(const HalfCheetahVariant& variant) {
  std::string xml = read_text_file(asset_path("half_cheetah.xml"));
  for (const auto& [geom, scale] : variant.geom_size_scale) xml = scale_geom_size(std::move(xml), geom, scale);
  return xml;
}

HalfCheetahEnv::HalfCheetahEnv(std::string task, std::int64_t task_index, HalfCheetahVariant variant)
    : MujocoEnv(half_cheetah_spec(task, task_index), compile_variant(task, variant), kFrameSkip),
      variant_(std::move(variant)) {
  if (model()->nq != 9 || model()->nv != 9 || model()->nu != kActionSize) {
    throw std::runtime_error("task '" + task + "': half_cheetah.xml must have nq = nv = 9 and nu = 6");
  }
}

Eigen::VectorXd HalfCheetahEnv::observation() const {
  const mjModel* m = model();
  const mjData* d = data();
  Eigen::VectorXd obs(kObservationSize);
  obs.head(m->nq - 1) = Eigen::Map<const Eigen::VectorXd>(d->qpos + 1, m->nq - 1);
  obs.tail(m->nv) = Eigen::Map<const Eigen::VectorXd>(d->qvel, m->nv);
  return obs;
}

double HalfCheetahEnv::x_position() const { return data()->qpos[0]; }
double HalfCheetahEnv::pitch() const { return data()->qpos[2]; }
bool HalfCheetahEnv::is_flipped() const { return std::cos(pitch()) < 0.0; }

Eigen::VectorXd HalfCheetahEnv::reset_model(std::mt19937_64& rng) {
  // Gym's reset: qpos0 + U(-0.1, 0.1) on all 9 positions (root x included), 0.1 N(0, 1) on all 9
  // velocities. libstdc++'s distributions are fixed code, so a seed gives the same state here.
  const mjModel* m = model();
  mjData* d = mutable_data();
  std::uniform_real_distribution<double> uniform(-kResetNoiseScale, kResetNoiseScale);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int i = 0; i < m->nq; ++i) d->qpos[i] = m->qpos0[i] + uniform(rng);
  for (int i = 0; i < m->nv; ++i) d->qvel[i] = kResetNoiseScale * normal(rng);
  mj_forward(m, d);
  return observation();
}

double HalfCheetahEnv::control_cost_weight() const { return kCtrlCostWeight; }

StepResult HalfCheetahEnv::step_clipped(const Eigen::VectorXd& action) {
  const double x_before = x_position();
  do_simulation(action);
  const double x_after = x_position();
  StepResult result;
  result.observation = observation();
  // Gym charges the control cost on the unclipped action (MuJoCo clamps ctrl itself); here
  // actions are clipped to [-1, 1] before anything else (DESIGN.md), so the cost uses the clipped
  // action. The two agree for every action inside the bounds.
  result.reward = (x_after - x_before) / dt() - kCtrlCostWeight * action.squaredNorm();
  result.terminated = false;  // HalfCheetah never terminates; the base adds the time limit
  result.success = false;     // and has no success test
  return result;
}

}  // namespace maps::envs
