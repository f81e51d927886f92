// window-open: slide a window's sash open (+x) by pushing its handle until the handle is within 5 cm (in x) of a
// goal 20 cm to the right of the closed window.

#include <memory>

#include "envs/mt10/tasks.h"
#include "envs/mt10/window_env.h"

namespace maps::envs::mt10 {
namespace {

class WindowOpenEnv : public WindowEnv {
 public:
  WindowOpenEnv(const std::string& task, std::int64_t index, MT10Options options)
      : WindowEnv(task, index, options, "handleOpenStart", 0.0) {}

 protected:
  void place_objects(std::mt19937_64& rng) override {
    const Eigen::Vector3d window{uniform(rng, -0.1, 0.1), uniform(rng, 0.7, 0.9), 0.16};
    place_window(window, window + Eigen::Vector3d(0.2, 0.0, 0.0));
  }
};

std::unique_ptr<MT10Env> make_window_open(const std::string& task, std::int64_t index, MT10Options options) {
  return std::make_unique<WindowOpenEnv>(task, index, options);
}

// The observed point is 2.6 cm left of the handle bar: approach from its left and push right.
Eigen::Vector4d window_open_expert(const Eigen::VectorXd& obs) { return push_window_handle(obs, -1.0, 0.3); }

const MT10TaskRegistration window_open_registration({"window-open", 8, make_window_open, window_open_expert, 1.0});

}  // namespace

}  // namespace maps::envs::mt10
