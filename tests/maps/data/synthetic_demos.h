#pragma once

#include <cmath>

#include "envs/demo_file.h"

// A small demo file of two tasks (S = 3, A = 2): demo d of task k follows a smooth trajectory and acts with a task's
// own smooth map, so that a policy can learn it. 6 demos per task (4 train, 2 valid), 40 steps each.
inline maps::envs::DemoFile synthetic_demo_file(int demos_per_task = 6, int steps = 40) {
  maps::envs::DemoFile file;
  file.task_set = "synthetic";
  file.task_names = {"synthetic/a", "synthetic/b"};
  file.env_version = "test";
  for (int k = 0; k < 2; ++k) {
    for (int d = 0; d < demos_per_task; ++d) {
      maps::envs::Demonstration demo;
      demo.task = file.task_names[k];
      demo.task_index = k;
      demo.seed = static_cast<std::uint64_t>(100 * k + d);
      demo.obs.resize(steps, 3);
      demo.actions.resize(steps, 2);
      demo.rewards.resize(steps);
      demo.dones.assign(steps, 0);
      demo.dones.back() = 1;
      for (int t = 0; t < steps; ++t) {
        const double phase = 0.15 * t + 0.7 * d + 2.0 * k;
        demo.obs.row(t) << std::sin(phase), std::cos(1.3 * phase), 0.05 * t;
        demo.actions.row(t) << std::sin(demo.obs(t, 0) + k), (k == 0 ? 1.0 : -1.0) * demo.obs(t, 1);
        demo.rewards[t] = 1.0 + k;
      }
      demo.episode_return = demo.rewards.sum();
      const int index = static_cast<int>(file.demos.size());
      (d < demos_per_task * 2 / 3 ? file.train : file.valid).push_back(index);
      file.demos.push_back(std::move(demo));
    }
  }
  return file;
}
