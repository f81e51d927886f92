#include "envs/mt10/tasks.h"

#include <algorithm>
#include <set>
#include <stdexcept>
#include <utility>

namespace maps::envs::mt10 {
namespace {

// The entries the task files' MT10TaskRegistration objects added, in the order they ran. Constructed on first use, so
// that a registration running during static initialisation, before or after anything else, finds it built.
std::vector<MT10Task>& registered_tasks() {
  static std::vector<MT10Task> tasks;
  return tasks;
}

std::string registered_list(const std::vector<MT10Task>& tasks) {
  std::string list;
  for (const MT10Task& task : tasks)
    list += (list.empty() ? "" : ", ") + task.name + " at " + std::to_string(task.index);
  return list.empty() ? "none" : list;
}

}  // namespace

MT10TaskRegistration::MT10TaskRegistration(MT10Task task) { registered_tasks().push_back(std::move(task)); }

std::vector<MT10Task> ordered_mt10_tasks(std::vector<MT10Task> tasks, std::int64_t count) {
  std::stable_sort(tasks.begin(), tasks.end(), [](const MT10Task& a, const MT10Task& b) { return a.index < b.index; });
  const auto refuse = [&](const std::string& what) {
    throw std::logic_error("MT10 task registry: " + what + "; registered: " + registered_list(tasks) +
                           " (each task file registers its task at its index in Meta-World's order, 0 to " +
                           std::to_string(count - 1) + ")");
  };
  std::set<std::string> names;
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    const MT10Task& task = tasks[i];
    if (task.index < 0 || task.index >= count)
      refuse("task '" + task.name + "' has index " + std::to_string(task.index) + ", outside 0 to " +
             std::to_string(count - 1));
    if (i > 0 && tasks[i - 1].index == task.index)
      refuse("tasks '" + tasks[i - 1].name + "' and '" + task.name + "' both have index " + std::to_string(task.index));
    if (!names.insert(task.name).second) refuse("task '" + task.name + "' is registered twice");
  }
  // The indices are now distinct and in range: a missing one is the first position holding another.
  for (std::int64_t i = 0; i < count; ++i)
    if (static_cast<std::size_t>(i) >= tasks.size() || tasks[static_cast<std::size_t>(i)].index != i)
      refuse("no task has index " + std::to_string(i) + ": a task file was not linked, or mt10_tasks() was called " +
             "by a static initialiser that ran before the task files registered theirs");
  return tasks;
}

const std::vector<MT10Task>& mt10_tasks() {
  // Ordered and checked once. A call that throws (a task missing) leaves it unbuilt: the next call checks again.
  static const std::vector<MT10Task> tasks = ordered_mt10_tasks(registered_tasks());
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
