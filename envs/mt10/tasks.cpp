#include "envs/mt10/tasks.h"

#include <stdexcept>

namespace maps::envs::mt10 {

const std::vector<MT10Task>& mt10_tasks() {
  // The last number: the expert's success rate measured by `maps expert-eval --set mt10 --episodes 100`.
  static const std::vector<MT10Task> tasks = {
      {"reach", make_reach, reach_expert, 1.0},
      {"push", make_push, push_expert, 1.0},
      {"pick-place", make_pick_place, pick_place_expert, 1.0},
      {"door-open", make_door_open, door_open_expert, 0.99},
      {"drawer-open", make_drawer_open, drawer_open_expert, 1.0},
      {"drawer-close", make_drawer_close, drawer_close_expert, 1.0},
      {"button-press-topdown", make_button_press_topdown, button_press_topdown_expert, 1.0},
      {"peg-insert-side", make_peg_insert_side, peg_insert_side_expert, 1.0},
      {"window-open", make_window_open, window_open_expert, 1.0},
      {"window-close", make_window_close, window_close_expert, 1.0},
  };
  return tasks;
}

const MT10Task& mt10_task(const std::string& name) {
  const std::string bare = name.rfind("mt10/", 0) == 0 ? name.substr(5) : name;
  for (const MT10Task& task : mt10_tasks())
    if (task.name == bare) return task;
  std::string message = "unknown MT10 task '" + name + "'; valid:";
  for (const MT10Task& task : mt10_tasks()) message += " mt10/" + task.name;
  throw std::invalid_argument(message);
}

}  // namespace maps::envs::mt10
