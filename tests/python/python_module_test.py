#!/usr/bin/python3
"""The `maps` Python module (issue 16, item 4): envs with Gymnasium's interface that replay the C++ demonstrations
exactly, demo files as numpy arrays, a trained run acting from numpy (the same actions and returns as `maps eval`),
MAPS's selector scores, and the autograd engine with grad and gradcheck from Python. Run by ctest as
python_module_test.py path/to/maps, with PYTHONPATH=<build>/python."""
import json
import math
import pathlib
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import maps

MAPS = None  # the maps tool, from argv
WORK = None  # a temporary folder: demo files and trained runs made once for every test


def tool(*args):
    proc = subprocess.run([MAPS, *map(str, args)], cwd=WORK, capture_output=True, text=True)
    if proc.returncode != 0:
        raise AssertionError(f"maps {' '.join(map(str, args))} exited {proc.returncode}:\n{proc.stderr}")
    return proc


def train(name, config):
    path = pathlib.Path(WORK) / f"{name}.json"
    path.write_text(json.dumps(config))
    tool("train", "--config", path, "--out", pathlib.Path(WORK) / name)
    return pathlib.Path(WORK) / name


def setUpModule():
    tool("collect", "--set", "gravity", "--demos", "3", "--out", "gravity.h5", "--threads", "1")
    tool("collect", "--set", "mt10", "--demos", "3", "--out", "mt10.h5", "--threads", "1")
    small = {"steps": 200, "validate_every": 100, "checkpoint_every": 100, "validation_states_per_task": 100}
    train("maps_mt10", {"method": "maps", "seed": 0, "data": {"file": str(pathlib.Path(WORK) / "mt10.h5")}, "train": small,
                        "maps": {"modules": 4}, "eval": {"episodes": 3, "threads": 1}})
    train("mt_bc_gravity", {"method": "mt_bc", "seed": 0, "data": {"file": "gravity.h5"}, "train": small,
                            "eval": {"episodes": 2, "threads": 1}})


class Envs(unittest.TestCase):
    def test_task_sets(self):
        self.assertEqual(maps.task_set_names(), ["gravity", "modified", "mt10"])
        self.assertEqual(len(maps.task_names("modified")), 11)
        self.assertEqual(maps.task_index("mt10/drawer-open"), maps.task_names("mt10").index("mt10/drawer-open"))
        with self.assertRaisesRegex(Exception, "gravity"):
            maps.task_names("no-such-set")

    def test_gymnasium_interface(self):
        env = maps.make_env("gravity/1.0")
        obs, info = env.reset(seed=7)
        self.assertEqual(obs.shape, env.observation_space.shape)
        self.assertEqual(obs.dtype, np.float64)
        self.assertEqual(info["seed"], 7)
        action = env.action_space.sample()
        self.assertTrue(env.action_space.contains(action))
        obs2, reward, terminated, truncated, info = env.step(action)
        self.assertEqual(obs2.shape, obs.shape)
        self.assertIsInstance(reward, float)
        self.assertFalse(terminated or truncated)
        self.assertIn("success", info)
        self.assertEqual(env.max_episode_steps, 1000)

    def test_same_seed_same_trajectory(self):
        for task in ("gravity/0.5", "modified/big_foot", "mt10/window-open"):
            with self.subTest(task=task):
                runs = []
                for _ in range(2):
                    env = maps.make_env(task)
                    rng = np.random.default_rng(3)
                    obs, _ = env.reset(seed=11)
                    rows = [obs]
                    for _ in range(50):
                        obs, reward, *_ = env.step(rng.uniform(-1, 1, env.action_space.shape))
                        rows.append(np.append(obs, reward))
                    runs.append(rows)
                for a, b in zip(*runs):
                    np.testing.assert_array_equal(a, b)

    def test_episode_ends_at_the_horizon(self):
        env = maps.make_env("mt10/reach")
        env.reset(seed=0)
        steps, truncated = 0, False
        while not truncated:
            _, _, terminated, truncated, _ = env.step(np.zeros(4))
            steps += 1
            self.assertFalse(terminated)
        self.assertEqual(steps, env.max_episode_steps)
        with self.assertRaisesRegex(Exception, "reset"):
            env.step(np.zeros(4))

    def test_bad_actions_and_tasks_are_refused_by_name(self):
        env = maps.make_env("gravity/0.5")
        env.reset(seed=0)
        with self.assertRaisesRegex(Exception, "gravity/0.5"):
            env.step(np.zeros(5))
        with self.assertRaisesRegex(Exception, "gravity/0.5"):
            env.step(np.full(6, np.nan))
        with self.assertRaisesRegex(Exception, "gravity/0.5"):
            maps.make_env("gravity/0.55")
        with self.assertRaises(ValueError):
            env.reset(seed=-1)

    def test_reset_without_seed_continues_from_the_last(self):
        env = maps.make_env("gravity/0.5")
        env.reset(seed=5)
        _, info = env.reset()
        self.assertEqual(info["seed"], 6)
        np.testing.assert_array_equal(env.reset()[0], maps.make_env("gravity/0.5").reset(seed=7)[0])


class DemoFiles(unittest.TestCase):
    def test_demos_replay_exactly_in_the_python_env(self):
        """A collected demonstration, replayed from its seed in the Python env, gives the same states and rewards."""
        for name in ("gravity.h5", "mt10.h5"):
            file = maps.read_demo_file(str(pathlib.Path(WORK) / name))
            self.assertEqual(file.format_version, 2)
            for demo in file.demos[:: len(file.demos) // 3]:
                with self.subTest(file=name, demo=repr(demo)):
                    env = maps.make_env(demo.task)
                    obs, _ = env.reset(seed=demo.seed)
                    np.testing.assert_array_equal(obs, demo.obs[0])
                    for t in range(demo.num_samples):
                        np.testing.assert_array_equal(obs, demo.obs[t])
                        obs, reward, terminated, truncated, _ = env.step(demo.actions[t])
                        self.assertEqual(reward, demo.rewards[t])
                        self.assertEqual(terminated or truncated, bool(demo.dones[t]))
                    np.testing.assert_array_equal(obs, demo.final_obs)
                    self.assertEqual(demo.end, "truncated" if truncated else "terminated")

    def test_the_experts_actions_are_the_recorded_ones(self):
        file = maps.read_demo_file(str(pathlib.Path(WORK) / "gravity.h5"))
        demo = file.demos[0]
        expert = maps.load_expert(demo.task)
        # Demonstrations record the action the env applied: the expert's, clipped to the bounds.
        np.testing.assert_array_equal(np.clip(expert.act(demo.obs[10]), -1, 1), demo.actions[10])

    def test_arrays_and_metadata(self):
        path = pathlib.Path(WORK) / "mt10.h5"
        file = maps.read_demo_file(str(path))
        self.assertEqual(file.task_set, "mt10")
        self.assertEqual(file.task_names, maps.task_names("mt10"))
        self.assertEqual(len(file), 30)
        self.assertEqual(sorted(file.train + file.valid), list(range(30)))
        arrays = maps.demo_arrays(path)
        n = file.total_samples
        self.assertEqual(arrays["observations"].shape, (n, 39))
        self.assertEqual(arrays["actions"].shape, (n, 4))
        self.assertEqual(int(arrays["timeouts"].sum() + arrays["terminals"].sum()), 30)
        np.testing.assert_array_equal(arrays["next_observations"][:-1][~arrays["timeouts"][:-1]],
                                      arrays["observations"][1:][~arrays["timeouts"][:-1]])
        train = maps.demo_arrays(file, split="train")
        self.assertEqual(len(np.unique(train["demo"])), 20)
        with self.assertRaisesRegex(ValueError, "split"):
            maps.demo_arrays(file, split="test")

    def test_a_file_written_from_python_reads_back(self):
        file = maps.read_demo_file(str(pathlib.Path(WORK) / "gravity.h5"))
        file.demos[0].rewards = file.demos[0].rewards * 2.0
        out = str(pathlib.Path(WORK) / "scaled.h5")
        maps.write_demo_file(out, file)
        back = maps.read_demo_file(out)
        np.testing.assert_array_equal(back.demos[0].rewards, file.demos[0].rewards)
        np.testing.assert_array_equal(back.demos[3].obs, file.demos[3].obs)
        bad = maps.read_demo_file(out)
        bad.demos[1].task_index = 99
        with self.assertRaisesRegex(ValueError, "demo_1"):
            maps.write_demo_file(out, bad)

    def test_missing_and_damaged_files_are_named(self):
        with self.assertRaisesRegex(Exception, "nowhere.h5"):
            maps.read_demo_file(str(pathlib.Path(WORK) / "nowhere.h5"))
        damaged = pathlib.Path(WORK) / "damaged.h5"
        damaged.write_bytes((pathlib.Path(WORK) / "mt10.h5").read_bytes()[:5000])
        with self.assertRaisesRegex(Exception, "damaged.h5"):
            maps.read_demo_file(str(damaged))


class Runs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.maps_run = maps.load_run(pathlib.Path(WORK) / "maps_mt10")
        # Trained on "gravity.h5", relative to the folder `maps train` ran in: data_file says where it is now.
        cls.baseline = maps.load_run(pathlib.Path(WORK) / "mt_bc_gravity", data_file=pathlib.Path(WORK) / "gravity.h5")

    def test_metadata(self):
        self.assertEqual(self.maps_run.method, "maps")
        self.assertEqual(self.maps_run.task_names, maps.task_names("mt10"))
        self.assertEqual(self.maps_run.config["maps"]["modules"], 4)
        self.assertEqual(self.maps_run.num_modules, 4)
        self.assertIn(self.maps_run.checkpoint["step"], (100, 200))
        self.assertEqual(self.baseline.demo_mean_returns.shape, (5,))

    @staticmethod
    def demo_states(step):
        """Every MT10 demo's state at `step`, with its task."""
        file = maps.read_demo_file(str(pathlib.Path(WORK) / "mt10.h5"))
        return file, np.stack([d.obs[step] for d in file.demos]), [d.task_index for d in file.demos]

    def test_batched_act_is_per_row_act(self):
        file, obs, tasks = self.demo_states(5)
        batch = self.maps_run.act(obs, tasks)
        self.assertEqual(batch.shape, (len(tasks), 4))
        for i in range(0, len(tasks), 7):
            np.testing.assert_allclose(self.maps_run.act(obs[i], tasks[i]), batch[i], rtol=0, atol=1e-6)
        np.testing.assert_array_equal(self.maps_run.act(obs[:2], file.demos[0].task),
                                      self.maps_run.act(obs[:2], [tasks[0]] * 2))

    def test_rollouts_give_maps_evals_returns(self):
        """Rolled out from Python on the evaluation seeds, the policy gets the returns `maps eval` reports."""
        tool("eval", "--run", self.maps_run.folder, "--threads", "1")
        evaluation = json.loads((pathlib.Path(self.maps_run.folder) / "eval.json").read_text())
        first_seed = evaluation["first_seed"]
        task = evaluation["tasks"][2]
        env = maps.make_env(task["task"])
        returns = []
        for episode in range(len(task["returns"])):
            obs, _ = env.reset(seed=first_seed + episode)
            total, done = 0.0, False
            while not done:
                obs, reward, terminated, truncated, _ = env.step(self.maps_run.act(obs, task["task"]))
                total += reward
                done = terminated or truncated
            returns.append(total)
        np.testing.assert_array_equal(returns, task["returns"])

    def test_selector_scores(self):
        _, obs, tasks = self.demo_states(0)
        scores = self.maps_run.selector_scores(obs, tasks)
        self.assertEqual(scores.shape, (len(tasks), 4))
        np.testing.assert_allclose(scores.sum(axis=1), 1.0, atol=1e-5)
        self.assertTrue((scores > 0).all())
        self.maps_run.force_module(2)
        try:
            np.testing.assert_array_equal(self.maps_run.selector_scores(obs, tasks), np.eye(4)[[2] * len(tasks)])
            forced = self.maps_run.act(obs, tasks)
        finally:
            self.maps_run.force_module(-1)
        self.assertFalse(np.allclose(forced, self.maps_run.act(obs, tasks)))
        with self.assertRaises(IndexError):
            self.maps_run.force_module(4)
        # routing() is the selector's scores for MAPS, and refused by name for a method without modules.
        np.testing.assert_array_equal(self.maps_run.routing(obs, tasks), scores)
        with self.assertRaisesRegex(TypeError, "mt_bc run, which has no modules"):
            self.baseline.routing(np.zeros(17), 0)

    def test_bad_inputs_are_refused_by_name(self):
        with self.assertRaisesRegex(ValueError, "39"):
            self.maps_run.act(np.zeros((2, 17)), 0)
        with self.assertRaisesRegex(IndexError, r"\[0, 10\)"):
            self.maps_run.act(np.zeros((1, 39)), 10)
        with self.assertRaisesRegex(ValueError, "not one of"):
            self.maps_run.act(np.zeros(39), "gravity/0.5")
        with self.assertRaisesRegex(ValueError, "2 tasks for 3"):
            self.maps_run.act(np.zeros((3, 39)), [0, 1])
        with self.assertRaisesRegex(ValueError, "NaN"):
            self.maps_run.act(np.full(39, np.nan), 0)
        with self.assertRaisesRegex(TypeError, "mt_bc"):
            self.baseline.selector_scores(np.zeros(17), 0)
        with self.assertRaisesRegex(Exception, "nowhere"):
            maps.load_run(pathlib.Path(WORK) / "nowhere")
        with self.assertRaisesRegex(Exception, "gravity.h5"):
            maps.load_run(pathlib.Path(WORK) / "mt_bc_gravity")  # its relative data file is not under this cwd
        with self.assertRaisesRegex(Exception, "not trained on demo file .*mt10.h5"):
            maps.load_run(pathlib.Path(WORK) / "mt_bc_gravity", data_file=pathlib.Path(WORK) / "mt10.h5")


class Autograd(unittest.TestCase):
    def test_numpy_round_trip_keeps_dtype(self):
        a = np.arange(6, dtype=np.float32).reshape(2, 3)
        t = maps.tensor(a)
        self.assertEqual((t.dtype, t.shape), ("float32", (2, 3)))
        np.testing.assert_array_equal(t.numpy(), a)
        self.assertEqual(maps.tensor([[1, 2]]).dtype, "float64")
        np.testing.assert_array_equal(np.asarray(maps.tensor([1.5, 2.5])), [1.5, 2.5])
        with self.assertRaises(ValueError):
            maps.tensor(["a", "b"])

    def test_grad_matches_the_formula(self):
        x = np.array([[0.3, -1.2], [2.0, 0.1]])
        w = np.array([[0.5], [-0.7]])
        xt, wt = maps.tensor(x, requires_grad=True), maps.tensor(w, requires_grad=True)
        loss = maps.sum(maps.tanh(xt @ wt) ** 2)
        gx, gw = maps.grad(loss, [xt, wt], retain_graph=True)
        y = np.tanh(x @ w)
        dy = 2 * y * (1 - y**2)
        np.testing.assert_allclose(gx.numpy(), dy @ w.T, rtol=1e-12)
        np.testing.assert_allclose(gw.numpy(), x.T @ dy, rtol=1e-12)
        loss.backward()
        np.testing.assert_allclose(wt.grad.numpy(), x.T @ dy, rtol=1e-12)

    def test_gradcheck_of_a_user_written_op(self):
        def softplus(a, b):
            return maps.log(1.0 + maps.exp(a * b)) / 2.0 - b

        rng = np.random.default_rng(0)
        a = maps.tensor(rng.normal(size=(3, 4)), requires_grad=True)
        b = maps.tensor(rng.normal(size=(3, 4)), requires_grad=True)
        self.assertTrue(maps.gradcheck(softplus, [a, b]))
        self.assertTrue(maps.gradgradcheck(softplus, [a, b]))
        self.assertTrue(maps.gradcheck(lambda x: maps.softmax(x, 1), [a]))

    def test_gradcheck_reports_failures(self):
        a = maps.tensor(np.ones((2, 2)), requires_grad=True)
        self.assertFalse(maps.gradcheck(lambda x: x * x, [a], atol=-1.0, rtol=0.0, raise_exception=False))
        with self.assertRaisesRegex(RuntimeError, "gradcheck failed"):
            maps.gradcheck(lambda x: x * x, [a], atol=-1.0, rtol=0.0)
        with self.assertRaisesRegex(ValueError, "Tensor"):
            maps.gradcheck(lambda x: 3.0, [a])

    def test_flush_denormal_flushes_products_below_the_smallest_normal(self):
        tiny = maps.tensor(np.array([1e-20], dtype=np.float32))
        self.assertGreater(float((tiny * tiny).numpy()[0]), 0.0)  # 1e-40: a float32 denormal
        self.assertTrue(maps.set_flush_denormal(True))
        try:
            self.assertEqual(float((tiny * tiny).numpy()[0]), 0.0)
        finally:
            maps.set_flush_denormal(False)
        self.assertGreater(float((tiny * tiny).numpy()[0]), 0.0)

    def test_second_order_and_no_grad(self):
        x = maps.tensor([0.4, -0.3], requires_grad=True)
        (g,) = maps.grad(maps.sum(x ** 3), [x], create_graph=True)
        (h,) = maps.grad(maps.sum(g), [x])
        np.testing.assert_allclose(h.numpy(), 6 * np.array([0.4, -0.3]), rtol=1e-12)
        with maps.no_grad():
            y = x * 2.0
        self.assertFalse(y.requires_grad)
        self.assertTrue(maps.is_grad_enabled())
        self.assertIsNone(maps.grad(maps.sum(x), [x, maps.tensor([1.0], requires_grad=True)],
                                    allow_unused=True)[1])


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit("usage: python_module_test.py path/to/maps")
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix="maps-python-") as work:
        WORK = work
        result = unittest.main(exit=False, verbosity=2).result
    sys.exit(0 if result.wasSuccessful() else 1)
