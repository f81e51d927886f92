"""A selector loss written in Python: the mean overlap of two tasks' module usage, over every pair of tasks in the
batch (examples/plugin/task_overlap_loss.cpp is the same loss in C++). A task's usage is its states' mean selector
scores, a point of the simplex over the M modules; the overlap of two is their dot product. Registered as
"task_overlap_py" when the file is imported, or loaded as a config's plugin (the `maps` tool runs it in its embedded
interpreter)."""

import numpy as np

import maps


class TaskOverlap(maps.SelectorLoss):
    def forward(self, outputs):
        tasks = np.asarray(outputs.tasks)
        usages = [maps.mean(outputs.scores[np.flatnonzero(tasks == k)], [0])
                  for k in range(outputs.num_tasks) if np.any(tasks == k)]
        if len(usages) < 2:
            return maps.sum(outputs.scores) * 0.0  # no pair of tasks: nothing to divide
        usage = maps.stack(usages, 0)  # [K, M]
        overlaps = maps.matmul(usage, maps.transpose(usage, 0, 1))  # [K, K]
        between = maps.sum(overlaps) - maps.sum(maps.square(usage))  # off the diagonal
        return between / (len(usages) * (len(usages) - 1))


maps.register_selector_loss("task_overlap_py", TaskOverlap)
