"""maps from Python: task sets and envs, demo files, trained runs and the autograd engine.

    import maps
    env = maps.make_env("gravity/0.5")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

    run = maps.load_run("runs/gravity-quick")
    actions = run.act(observations, tasks)          # numpy [n, S] in, [n, A] out
    scores = run.selector_scores(observations, tasks)  # MAPS: [n, M]

    demos = maps.read_demo_file("data/gravity.h5")  # demos.demos[i].obs, .actions, ... as numpy
    x = maps.tensor([1.0, 2.0], requires_grad=True)
    (g,) = maps.grad(maps.sum(maps.tanh(x)), [x])

docs/python.md has the whole tour.
"""

import contextlib
import json

import numpy as np

from ._maps import (  # noqa: F401  (re-exported)
    DemoFile,
    Demonstration,
    Tensor,
    abs,
    clamp,
    concat,
    exp,
    grad,
    gradcheck,
    gradgradcheck,
    is_grad_enabled,
    log,
    log_softmax,
    matmul,
    maximum,
    mean,
    minimum,
    mse_loss,
    num_threads,
    read_demo_file,
    relu,
    set_flush_denormal,
    set_grad_enabled,
    set_num_threads,
    sigmoid,
    softmax,
    sqrt,
    square,
    stack,
    sum,
    tanh,
    task_index,
    task_names,
    task_set_names,
    task_set_of,
    write_demo_file,
)
from . import _maps

__all__ = [
    "Box", "DemoFile", "Demonstration", "Env", "Expert", "Run", "Tensor", "demo_arrays", "grad", "gradcheck",
    "gradgradcheck", "load_expert", "load_run", "make_env", "no_grad", "read_demo_file", "task_names",
    "task_set_names", "tensor", "write_demo_file",
]


def tensor(data, dtype=None, requires_grad=False):
    """A Tensor from a numpy array or nested lists: float32 stays float32, anything else becomes float64."""
    return Tensor(data, dtype, requires_grad)


@contextlib.contextmanager
def no_grad():
    """Nothing is recorded for backward inside the block (like torch.no_grad)."""
    previous = is_grad_enabled()
    set_grad_enabled(False)
    try:
        yield
    finally:
        set_grad_enabled(previous)


class Box:
    """A box space as Gymnasium's spaces.Box describes one: low, high, shape, dtype, sample(), contains()."""

    def __init__(self, low, high, dtype=np.float64, seed=None):
        self.low = np.asarray(low, dtype=dtype)
        self.high = np.asarray(high, dtype=dtype)
        self.shape = self.low.shape
        self.dtype = np.dtype(dtype)
        self._rng = np.random.default_rng(seed)

    def seed(self, seed=None):
        self._rng = np.random.default_rng(seed)

    def sample(self):
        low = np.where(np.isfinite(self.low), self.low, -1.0)
        high = np.where(np.isfinite(self.high), self.high, 1.0)
        return self._rng.uniform(low, high).astype(self.dtype)

    def contains(self, x):
        x = np.asarray(x)
        return x.shape == self.shape and bool(np.all(x >= self.low) and np.all(x <= self.high))

    def __repr__(self):
        return f"Box({self.low.min()}, {self.high.max()}, {self.shape}, {self.dtype})"


class Env:
    """A task's env with Gymnasium's interface: reset(seed=None) -> (obs, info); step(action) -> (obs, reward,
    terminated, truncated, info). info holds "success" (the task's success test at this step) and
    "in_failure_state" (HalfCheetah turned over). reset(seed=s) gives the initial state the C++ env gives for s,
    which is the seed a demonstration records; reset() without a seed uses the previous seed + 1."""

    metadata = {"render_modes": []}

    def __init__(self, task):
        self._env = _maps._make_env(task)
        self.task = self._env.task
        self.task_index = self._env.task_index
        self.max_episode_steps = self._env.horizon
        self.observation_space = Box(np.full(self._env.observation_size, -np.inf),
                                     np.full(self._env.observation_size, np.inf))
        self.action_space = Box(self._env.action_low, self._env.action_high)
        self._next_seed = None

    def reset(self, seed=None, options=None):
        del options  # Gymnasium's signature; no option is defined
        if seed is None:
            seed = 0 if self._next_seed is None else self._next_seed
        seed = int(seed)
        if seed < 0 or seed >= 2**64:
            raise ValueError(f"seed must be in [0, 2**64), not {seed}")
        self._next_seed = (seed + 1) % 2**64
        observation = np.asarray(self._env.reset(seed))
        return observation, {"seed": seed, "task": self.task, "task_index": self.task_index}

    def step(self, action):
        action = np.asarray(action, dtype=np.float64).reshape(-1)
        observation, reward, terminated, truncated, success, failure = self._env.step(action)
        return (np.asarray(observation), reward, terminated, truncated,
                {"success": success, "in_failure_state": failure})

    def close(self):
        pass

    def __repr__(self):
        return f"<maps.Env {self.task}>"


def make_env(task):
    """The env of a task named as in maps.task_names(set), e.g. "gravity/0.5", "mt10/drawer-open"."""
    return Env(task)


class Expert:
    """A task's committed expert: act(obs) is its mean action, sample(obs) adds its exploration noise."""

    def __init__(self, task, seed=0):
        self._expert = _maps._load_expert(task, seed)
        self.task = self._expert.task
        self.source = self._expert.source

    def act(self, observation):
        return np.asarray(self._expert.act(np.asarray(observation, dtype=np.float64)))

    def sample(self, observation):
        return np.asarray(self._expert.sample(np.asarray(observation, dtype=np.float64)))


def load_expert(task, seed=0):
    return Expert(task, seed)


class Run:
    """A trained run folder (maps train --out DIR) at a checkpoint, as `maps eval` loads it (see load_run).

    act(observations, tasks) and selector_scores(observations, tasks) take raw observations, [n, S] or one [S],
    and tasks as one task (index or name) for every row or one per row; they return numpy arrays [n, A] and
    [n, M] (or [A], [M] for one observation). Actions are the policy's mean actions, not clipped (the env clips).
    """

    def __init__(self, folder, checkpoint="best.ckpt", data_file=None):
        self._run = _maps._Run(str(folder), checkpoint, "" if data_file is None else str(data_file))
        self.folder = self._run.folder
        self.method = self._run.method
        self.config = json.loads(self._run.config_json)
        self.checkpoint = json.loads(self._run.checkpoint_json)
        self.task_set = self._run.task_set
        self.task_names = list(self._run.task_names)
        self.observation_size = self._run.observation_size
        self.action_size = self._run.action_size
        self.demo_mean_returns = np.asarray(self._run.demo_mean_returns)

    def task_indices(self, tasks, rows):
        """tasks as a list of task indices for `rows` observations."""
        if isinstance(tasks, (str, int, np.integer)):
            tasks = [tasks] * rows
        tasks = list(tasks)
        if len(tasks) != rows:
            raise ValueError(f"{len(tasks)} tasks for {rows} observations")
        indices = []
        for task in tasks:
            if isinstance(task, str):
                if task not in self.task_names:
                    raise ValueError(f"task {task!r} is not one of {self.folder}'s tasks: {self.task_names}")
                indices.append(self.task_names.index(task))
            else:
                indices.append(int(task))
        return indices

    def _call(self, fn, observations, tasks):
        observations = np.asarray(observations, dtype=np.float64)
        single = observations.ndim == 1
        if observations.ndim not in (1, 2):
            raise ValueError(f"observations must be [S] or [n, S], not shape {observations.shape}")
        batch = observations.reshape(1, -1) if single else observations
        result = np.asarray(fn(batch, self.task_indices(tasks, batch.shape[0])))
        return result[0] if single else result

    def act(self, observations, tasks):
        return self._call(self._run.act, observations, tasks)

    def selector_scores(self, observations, tasks):
        return self._call(self._run.selector_scores, observations, tasks)

    def routing(self, observations, tasks):
        """Each row's shares [n, M] over the policy's modules, for any method that routes: MAPS's selector scores,
        MOORE's and PaCo's task-weight shares, the CARE-style attention, the top-k gates, Soft Modularization's
        per-layer use (docs/zoo.md). A method without modules raises TypeError."""
        return self._call(self._run.routing, observations, tasks)

    @property
    def num_modules(self):
        return self._run.num_modules

    def force_module(self, module):
        """Puts every selector score on one module (-1: the selector's own scores again), the paper's Fig. 6 probe."""
        self._run.force_module(module)

    def __repr__(self):
        return f"<maps.Run {self.folder}: {self.method} on {self.task_set}, step {self.checkpoint.get('step')}>"


def load_run(folder, checkpoint="best.ckpt", data_file=None):
    """The run in `folder` at `checkpoint` (best.ckpt, or step_<N>.ckpt kept by train.keep_every). It reads the demo
    file it was trained on (for the observation statistics, and MAML's fine-tuning): the config's data.file, which
    is relative to the folder `maps train` ran in when it was given so; data_file names it from here instead."""
    return Run(folder, checkpoint, data_file)


def demo_arrays(path_or_file, split=None):
    """A demo file's demonstrations as flat numpy arrays, D4RL-style: observations, actions, rewards, terminals,
    timeouts, next_observations (where the file records them: format 2), task_index, demo (the demo's index in the
    file), seed. split: None for every demo, "train" or "valid" for that mask."""
    file = read_demo_file(str(path_or_file)) if not isinstance(path_or_file, DemoFile) else path_or_file
    if split is None:
        indices = range(len(file))
    elif split in ("train", "valid"):
        indices = getattr(file, split)
    else:
        raise ValueError(f"split must be None, 'train' or 'valid', not {split!r}")
    demos = file.demos
    parts = {key: [] for key in ("observations", "actions", "rewards", "terminals", "timeouts", "task_index", "demo",
                                 "seed", "next_observations")}
    has_next = file.format_version >= 2
    for i in indices:
        d = demos[i]
        steps = d.num_samples
        last = np.zeros(steps, dtype=bool)
        last[-1] = True
        parts["observations"].append(np.asarray(d.obs))
        parts["actions"].append(np.asarray(d.actions))
        parts["rewards"].append(np.asarray(d.rewards))
        parts["terminals"].append(last & (d.end == "terminated"))
        parts["timeouts"].append(last & (d.end != "terminated"))
        parts["task_index"].append(np.full(steps, d.task_index, dtype=np.int64))
        parts["demo"].append(np.full(steps, i, dtype=np.int64))
        parts["seed"].append(np.full(steps, d.seed, dtype=np.uint64))
        if has_next:
            parts["next_observations"].append(np.vstack([np.asarray(d.obs)[1:], np.asarray(d.final_obs)[None, :]]))
    if not has_next:
        del parts["next_observations"]
    return {key: np.concatenate(value) if value else np.zeros(0) for key, value in parts.items()}
