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

    net = maps.nn.MLP([3, 16, 1], "tanh")             # maps.nn: modules, Parameter, save/load (torch.nn's names)
    optimizer = maps.optim.Adam(net.parameters(), lr=1e-2)

docs/python.md has the whole tour.
"""

import contextlib
import json

import numpy as np

from ._maps import (  # noqa: F401  (re-exported)
    DemoFile,
    Demonstration,
    Generator,
    Tensor,
    abs,
    add,
    amax,
    arange,
    clamp,
    concat,
    div,
    eq,
    erf,
    exp,
    expand,
    full,
    grad,
    gradcheck,
    gradgradcheck,
    gt,
    index_select,
    is_grad_enabled,
    linear,
    log,
    log_softmax,
    manual_seed,
    matmul,
    maximum,
    mean,
    minimum,
    mse_loss,
    mul,
    narrow,
    neg,
    num_threads,
    one_hot,
    ones,
    pow,
    rand,
    randn,
    read_demo_file,
    relu,
    reshape,
    set_flush_denormal,
    set_grad_enabled,
    set_num_threads,
    sigmoid,
    softmax,
    softplus,
    sqrt,
    square,
    stack,
    sub,
    sum,
    tanh,
    task_index,
    task_names,
    task_set_names,
    task_set_of,
    transpose,
    where,
    write_demo_file,
    zeros,
)
from . import _maps
from . import nn, optim  # noqa: F401  (maps.nn, maps.optim)

__all__ = [
    "Box", "DemoFile", "Demonstration", "Env", "Expert", "Generator", "Run", "Tensor", "demo_arrays", "grad",
    "gradcheck", "gradgradcheck", "load_expert", "load_run", "make_env", "manual_seed", "nn", "no_grad", "optim",
    "read_demo_file", "task_names", "task_set_names", "tensor", "write_demo_file",
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

    @property
    def policy(self):
        """The policy as a maps.nn.Module (named_parameters, state_dict, to, ...): the one act() and forward() run."""
        return self._run.policy

    def named_parameters(self):
        """The policy's [(name, Tensor)]: its own tensors (sharing storage), leaves that require grad."""
        return self._run.policy.named_parameters()

    def parameters(self):
        return self._run.policy.parameters()

    def forward(self, observations, tasks):
        """The policy's mean actions as a maps.Tensor on the graph: [n, A] for raw observations [n, S] (or [A] for
        one [S]), standardised as act() does them, in grad mode as it is (on unless maps.no_grad()). Gradients reach
        the policy's parameters (named_parameters()), and the observations when they are a maps.Tensor that
        requires grad. The policy computes in its dtype: float32 as trained, float64 after run.policy.to("float64")
        (for gradcheck)."""
        if isinstance(observations, Tensor):
            if observations.ndim not in (1, 2):
                raise ValueError(f"observations must be [S] or [n, S], not shape {observations.shape}")
            single = observations.ndim == 1
            batch = observations.reshape(1, -1) if single else observations
            rows = batch.shape[0]
        else:
            observations = np.asarray(observations, dtype=np.float64)
            if observations.ndim not in (1, 2):
                raise ValueError(f"observations must be [S] or [n, S], not shape {observations.shape}")
            single = observations.ndim == 1
            batch = observations.reshape(1, -1) if single else observations
            rows = batch.shape[0]
        actions = self._run.forward(batch, self.task_indices(tasks, rows))
        return actions[0] if single else actions

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


# ----- your own selector losses and methods, trained by the C++ trainer (docs/extending.md) --------------------------

from ._maps import Batch, PolicyShape, SelectorOutputs  # noqa: E402,F401  (re-exported)


class SelectorLoss(_maps.SelectorLoss):
    """Base of a selector loss written in Python: define forward(self, outputs) returning a scalar Tensor in the
    scores' dtype, differentiable in them (outputs: SelectorOutputs, with scores [b, M], all_task_scores [K, b, M],
    previous_scores [b, M], tasks, num_tasks, num_modules), and register the class with register_selector_loss. MAPS
    calls it on every training step, weighted as the run config's maps.selector_losses says."""

    def __init__(self):
        super().__init__(type(self).__name__)

    def forward(self, outputs):
        raise NotImplementedError(f"{type(self).__name__} defines no forward(self, outputs)")


class Policy(_maps.Policy):
    """Base of a multi-task policy written in Python. __init__(self, shape, generator) calls
    super().__init__(shape), then assigns its maps.nn modules and Parameters (initialised from `generator`, so a
    run's seed decides them); act(self, observations, tasks) returns the mean actions [n, A] for standardised
    observations [n, S]; loss(self, batch) returns a scalar Tensor (e.g. self.bc_loss(self.act(batch.observations,
    batch.tasks), batch)) or a dict of named scalar terms whose sum is minimised. Register the class with
    register_method."""

    def __init__(self, shape):
        super().__init__(shape, type(self).__name__)

    def act(self, observations, tasks):
        raise NotImplementedError(f"{type(self).__name__} defines no act(self, observations, tasks)")

    def loss(self, batch):
        return self.bc_loss(self.act(batch.observations, batch.tasks), batch)


def register_selector_loss(name, cls):
    """Makes the SelectorLoss subclass `cls` known as `name` to run configs (maps.selector_losses), maps.train and,
    from a Python plugin file, the `maps` tool. Registering the same class again does nothing; a name a built-in or
    another class has is a ValueError naming both. Returns `cls` (usable as a decorator's result)."""
    _maps._register_selector_loss(name, cls)
    return cls


def register_method(name, cls, summary=""):
    """Makes the Policy subclass `cls` known as method `name` (a run config's "method") to maps.train and, from a
    Python plugin file, the `maps` tool. Returns `cls`."""
    _maps._register_method(name, cls, summary)
    return cls


def selector_loss_names():
    """Every selector loss known: the paper's four, then the registered ones."""
    return _maps.selector_loss_names()


def method_names():
    """Every method known: the built-ins, then the registered ones."""
    return _maps.method_names()


def _load_plugin_file(path):
    """Runs a config's Python plugin (called by the plugin loader, here or in the tool's embedded interpreter): the
    file is imported as the module named after it, with its folder on sys.path so it can import its neighbours; a
    module of that name already imported from the same file is not run again (its classes are registered)."""
    import importlib.util
    import os
    import sys

    path = os.path.realpath(path)
    name = os.path.splitext(os.path.basename(path))[0]
    loaded = sys.modules.get(name)
    if loaded is not None and os.path.realpath(getattr(loaded, "__file__", "") or "") == path:
        return loaded
    folder = os.path.dirname(path)
    if folder not in sys.path:
        sys.path.insert(0, folder)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def train(config, out, *, selector_losses=None, policy=None, overrides=(), threads=1, print_config=False):
    """Trains one run as `maps train --config CONFIG --out OUT` does, with the same C++ trainer: progress on stdout,
    the run folder (config.json, checkpoints, curve.csv, train.log, provenance.json), resume when OUT holds a run of
    the same config, extension when only train.steps grew.

    config: a dict (a run config, docs/configs.md) or the path of a JSON file. Its "plugins" may name Python files
    (and C++ plugins) as for the tool; a run whose Python pieces come from a plugin file can later be evaluated by
    `maps eval` and run by `maps suite`.
    selector_losses: {name: SelectorLoss subclass} registered before the config is read.
    policy: a Policy subclass, registered as the config's "method" (set to the class's name in lowercase when the
    config names none).
    overrides: "key=value" strings, as --set. threads: op threads (0: one per core).
    Returns OUT."""
    import os

    for name, cls in (selector_losses or {}).items():
        register_selector_loss(name, cls)
    config_path = ""
    if isinstance(config, (str, os.PathLike)):
        config_path = os.fspath(config)
        if policy is not None:
            raise ValueError("maps.train: give the config as a dict to train a `policy` class (its method name "
                             "goes in the config)")
        config_json = ""
    else:
        config = dict(config)
        if policy is not None:
            method = config.setdefault("method", policy.__name__.lower())
            register_method(method, policy)
        config_json = json.dumps(config)
    if threads == 0:
        threads = os.cpu_count() or 1
    code = _maps._train(config_json, config_path, os.fspath(out), list(overrides), int(threads), bool(print_config))
    if code != 0:
        raise RuntimeError(f"maps.train: training into {out} stopped with code {code}")
    return out
