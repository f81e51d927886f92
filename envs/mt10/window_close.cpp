// window-close: slide an open window's sash shut (-x) by pushing its handle until the handle is within 5 cm (in x)
// of the closed position.

#include <memory>

#include "envs/mt10/tasks.h"
#include "envs/mt10/window_env.h"

namespace maps::envs::mt10 {
namespace {

constexpr double kOpen = 0.2;  // the sash's full travel; every episode starts fully open

class WindowCloseEnv : public WindowEnv {
 public:
  WindowCloseEnv(const std::string& task, std::int64_t index, MT10Options options)
      : WindowEnv(task, index, options, "handleCloseStart", kOpen) {}

 protected:
  void place_objects(std::mt19937_64& rng) override {
    // Only y varies, and the window stands 4 cm higher than in window-open (Meta-World's ranges).
    const Eigen::Vector3d window{0.0, uniform(rng, 0.75, 0.9), 0.2};
    place_window(window, window);
  }
};

std::unique_ptr<MT10Env> make_window_close(const std::string& task, std::int64_t index, MT10Options options) {
  return std::make_unique<WindowCloseEnv>(task, index, options);
}

// The mirror image of window-open's: the observed point is 2.4 cm right of the handle bar; approach from its right
// and push left.
Eigen::Vector4d window_close_expert(const Eigen::VectorXd& obs) { return push_window_handle(obs, 1.0, 0.25); }

const MT10TaskRegistration window_close_registration({"window-close", 9, make_window_close, window_close_expert, 1.0});

}  // namespace

}  // namespace maps::envs::mt10
