#!/usr/bin/python3
"""The nn layer from Python (issue 43, item 2): maps.nn's modules (Linear, MLP, Sequential, ModuleList, activations,
modules defined in Python), maps.optim's Adam and SGD, checkpoint files through maps.nn.save/load, tensor indexing
with gradients, and a trained run's parameters and differentiable forward. Run by ctest as nn_test.py path/to/maps,
with PYTHONPATH=<build>/python."""
import gc
import json
import pathlib
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import maps
import maps.nn.functional as F

MAPS = None  # the maps tool, from argv
WORK = None  # a temporary folder: a demo file and a tiny trained run, made once


def setUpModule():
    def tool(*args):
        proc = subprocess.run([MAPS, *map(str, args)], cwd=WORK, capture_output=True, text=True)
        if proc.returncode != 0:
            raise AssertionError(f"maps {' '.join(map(str, args))} exited {proc.returncode}:\n{proc.stderr}")

    tool("collect", "--set", "gravity", "--demos", "2", "--out", "gravity.h5", "--threads", "1")
    config = {"method": "maps", "seed": 0, "data": {"file": str(pathlib.Path(WORK) / "gravity.h5")},
              "train": {"steps": 20, "validate_every": 10, "checkpoint_every": 10, "validation_states_per_task": 20},
              "maps": {"modules": 2, "module_hidden": [8, 8], "selector_hidden": [8]}}
    (pathlib.Path(WORK) / "run.json").write_text(json.dumps(config))
    tool("train", "--config", "run.json", "--out", "run")
    config["data"]["observation_clip"] = 0.5  # a run on clamped inputs (Runs.test_forward_clamps_as_act_does)
    (pathlib.Path(WORK) / "run_clip.json").write_text(json.dumps(config))
    tool("train", "--config", "run_clip.json", "--out", "run_clip")


def float64(*shape, seed=0):
    return maps.tensor(np.random.default_rng(seed).normal(size=shape), requires_grad=True)


class Indexing(unittest.TestCase):
    KEYS = [1, -1, slice(1, None), slice(None, None, 2), slice(None, None, -1), slice(3, 1, -1), slice(5, 9),
            (1, 2), (-1, slice(0, 2)), (slice(None), -2), (slice(None), slice(None), [3, 0, 0]), [2, 0], [-1],
            np.array([1, 0]), [True, False, True], (Ellipsis, 1), (None, 1), (1, None, Ellipsis, slice(1, 3)), (),
            np.int64(1), (slice(None), [])]

    def test_values_and_shapes_are_numpys(self):
        a = np.arange(3 * 4 * 5, dtype=np.float64).reshape(3, 4, 5)
        t = maps.tensor(a)
        for key in self.KEYS:
            with self.subTest(key=key):
                np.testing.assert_array_equal(t[key].numpy(), a[key])
                self.assertEqual(t[key].shape, a[key].shape)

    def test_gradients_flow_through_every_kind_of_index(self):
        x = float64(3, 4, 5)
        for key in self.KEYS:
            with self.subTest(key=key):
                self.assertTrue(maps.gradcheck(lambda t: t[key] * 2.0, [x]))
        # The gradient of a picked row is one there, zero elsewhere; a row picked twice gets two.
        (g,) = maps.grad(maps.sum(x[[2, 0, 2]]), [x])
        np.testing.assert_array_equal(g.numpy()[:, 0, 0], [1.0, 0.0, 2.0])

    def test_bad_indices_are_refused_naming_them(self):
        t = maps.tensor(np.zeros((3, 4)))
        with self.assertRaisesRegex(IndexError, "index 3 is out of range for dim 0 of size 3"):
            t[3]
        with self.assertRaisesRegex(IndexError, "index -5 is out of range for dim 1 of size 4"):
            t[0, -5]
        with self.assertRaisesRegex(IndexError, "index 7 is out of range for dim 1 of size 4"):
            t[:, [0, 7]]
        with self.assertRaisesRegex(IndexError, "too many indices"):
            t[0, 0, 0]
        with self.assertRaisesRegex(IndexError, "one list or array"):
            t[[0, 1], [0, 1]]
        with self.assertRaisesRegex(IndexError, "mask of length 2"):
            t[[True, False]]
        with self.assertRaises(TypeError):
            t[1.5]
        with self.assertRaises(TypeError):
            t[maps.tensor([0.0])]

    def test_len_and_iteration(self):
        t = maps.tensor(np.arange(6.0).reshape(3, 2))
        self.assertEqual(len(t), 3)
        self.assertEqual([row.numpy().tolist() for row in t], [[0, 1], [2, 3], [4, 5]])
        with self.assertRaises(TypeError):
            len(maps.tensor(1.0))


class Ops(unittest.TestCase):
    def test_functional_ops_match_numpy_and_their_gradients(self):
        x = float64(3, 4)
        w, b = float64(2, 4, seed=1), float64(2, seed=2)
        xn, wn, bn = x.numpy(), w.numpy(), b.numpy()
        np.testing.assert_allclose(maps.softplus(x).numpy(), np.log1p(np.exp(xn)), rtol=1e-12)
        np.testing.assert_allclose(F.linear(x, w, b).numpy(), xn @ wn.T + bn, rtol=1e-12)
        np.testing.assert_allclose(maps.amax(x, 1).numpy(), xn.max(axis=1))
        np.testing.assert_allclose(x.sum(0).numpy(), xn.sum(axis=0), rtol=1e-12)
        np.testing.assert_array_equal(maps.index_select(x, 1, [3, 0]).numpy(), xn[:, [3, 0]])
        np.testing.assert_array_equal(maps.narrow(x, 1, 1, 2).numpy(), xn[:, 1:3])
        np.testing.assert_array_equal(maps.clamp(x, min=0.0).numpy(), np.maximum(xn, 0.0))
        np.testing.assert_array_equal(maps.where(maps.gt(x, maps.zeros([3, 4], "float64")), x, x * 0.0).numpy(),
                                      np.where(xn > 0, xn, 0.0))
        self.assertEqual(x.unsqueeze(0).shape, (1, 3, 4))
        self.assertEqual(x.reshape(4, 3).shape, (4, 3))
        self.assertEqual(x.unsqueeze(-1).squeeze().shape, (3, 4))
        for name, fn in [("softplus", maps.softplus), ("erf", maps.erf), ("linear", lambda t: F.linear(t, w, b)),
                         ("index_select", lambda t: maps.index_select(t, 1, [3, 0, 3])),
                         ("amax", lambda t: maps.amax(t, 0)), ("clamp", lambda t: maps.clamp(t, max=0.5)),
                         ("mse", lambda t: F.mse_loss(t, t * t))]:
            with self.subTest(op=name):
                self.assertTrue(maps.gradcheck(fn, [x]))

    def test_seeded_factories(self):
        maps.manual_seed(5)
        a = maps.randn([2, 3])
        maps.manual_seed(5)
        np.testing.assert_array_equal(maps.randn([2, 3]).numpy(), a.numpy())
        np.testing.assert_array_equal(maps.randn([2, 3], generator=maps.Generator(5)).numpy(), a.numpy())
        self.assertEqual(maps.zeros([2], "float64").dtype, "float64")
        np.testing.assert_array_equal(maps.arange(4).numpy(), [0, 1, 2, 3])
        self.assertTrue(maps.ones([1], requires_grad=True).requires_grad)


class Net(maps.nn.Module):
    """A module defined in Python: a parameter and a child Linear."""

    def __init__(self, generator=None, hidden=16):
        super().__init__()
        self.body = maps.nn.Linear(3, hidden, generator=generator)
        self.w = maps.nn.Parameter(maps.randn([hidden, 1], generator=generator) * 0.1)
        self.note = "a plain attribute"

    def forward(self, x):
        return maps.tanh(self.body(x)) @ self.w


def regression(rows=64):
    x = np.random.default_rng(0).uniform(-1, 1, (rows, 3)).astype(np.float32)
    y = np.sin(2 * x[:, :1]) + 0.5 * x[:, 1:2] * x[:, 2:3]
    return maps.tensor(x), maps.tensor(y.astype(np.float32))


class Modules(unittest.TestCase):
    def test_linear(self):
        layer = maps.nn.Linear(3, 2, generator=maps.Generator(1))
        self.assertEqual([(n, p.shape) for n, p in layer.named_parameters()], [("weight", (2, 3)), ("bias", (2,))])
        self.assertTrue(all(p.requires_grad and p.is_leaf for p in layer.parameters()))
        x = np.random.default_rng(0).normal(size=(4, 3)).astype(np.float32)
        np.testing.assert_allclose(layer(maps.tensor(x)).numpy(), x @ layer.weight.numpy().T + layer.bias.numpy(),
                                   rtol=1e-5, atol=1e-6)
        bound = 1 / np.sqrt(3)
        self.assertTrue(np.all(np.abs(layer.weight.numpy()) <= bound))
        np.testing.assert_array_equal(maps.nn.Linear(3, 2, generator=maps.Generator(1)).weight.numpy(),
                                      layer.weight.numpy())
        self.assertIsNone(maps.nn.Linear(3, 2, bias=False).bias)
        self.assertEqual(maps.nn.Linear(3, 2, dtype="float64").weight.dtype, "float64")
        self.assertEqual(repr(layer), "Linear(in_features=3, out_features=2, bias=True)")
        with self.assertRaisesRegex(ValueError, r"expected input \[batch, 3\]"):
            layer(maps.tensor(np.zeros((4, 5), dtype=np.float32)))

    def test_mlp_and_sequential_compute_their_layers(self):
        mlp = maps.nn.MLP([3, 5, 2], "tanh", dtype="float64")
        self.assertEqual([n for n, _ in mlp.named_parameters()],
                         ["layers.0.weight", "layers.0.bias", "layers.1.weight", "layers.1.bias"])
        self.assertEqual((mlp.sizes, mlp.activation, mlp.num_layers), ([3, 5, 2], "tanh", 2))
        x = float64(4, 3)
        manual = mlp.layer(1)(maps.tanh(mlp.layer(0)(x)))
        np.testing.assert_allclose(mlp(x).numpy(), manual.numpy(), rtol=1e-12)
        self.assertTrue(maps.gradcheck(lambda t: mlp(t), [x]))
        sequential = maps.nn.Sequential(mlp.layer(0), maps.nn.Tanh(), mlp.layer(-1))
        np.testing.assert_allclose(sequential(x).numpy(), manual.numpy(), rtol=1e-12)
        self.assertEqual([n for n, _ in sequential.named_parameters()],
                         ["0.weight", "0.bias", "2.weight", "2.bias"])
        self.assertEqual(len(sequential), 3)
        self.assertIsInstance(sequential[1], maps.nn.Tanh)
        self.assertIs(sequential.append(maps.nn.ReLU()), sequential)
        self.assertEqual([type(m).__name__ for m in sequential], ["Linear", "Tanh", "Linear", "ReLU"])
        with self.assertRaisesRegex(IndexError, "index 4 is out of range for 4"):
            sequential[4]
        with self.assertRaisesRegex(TypeError, "maps.nn.Module"):
            maps.nn.Sequential(maps.nn.Tanh(), 3)
        for activation, fn in [(maps.nn.ReLU(), np.maximum), (maps.nn.Sigmoid(), None), (maps.nn.Identity(), None)]:
            out = activation(x).numpy()
            expected = {"ReLU": np.maximum(x.numpy(), 0), "Sigmoid": 1 / (1 + np.exp(-x.numpy())),
                        "Identity": x.numpy()}[activation.type_name]
            np.testing.assert_allclose(out, expected, rtol=1e-12)
        items = maps.nn.ModuleList([maps.nn.Tanh(), mlp])
        self.assertEqual(len(items), 2)
        self.assertEqual(items.parameter_count(), mlp.parameter_count())
        self.assertEqual(mlp.parameter_count(), 3 * 5 + 5 + 5 * 2 + 2)

    def test_parallel_linear(self):
        layer = maps.nn.ParallelLinear(3, 4, 2, dtype="float64")
        x = float64(5, 4)
        out = layer(x)
        self.assertEqual(out.shape, (3, 5, 2))
        np.testing.assert_allclose(out[1].numpy(), x.numpy() @ layer.weight.numpy()[1] + layer.bias.numpy()[1],
                                   rtol=1e-12)

    def test_module_methods(self):
        net = Net(maps.Generator(0))
        self.assertEqual([n for n, _ in net.named_parameters()], ["w", "body.weight", "body.bias"])
        self.assertEqual([n for n, _ in net.named_modules()], ["", "body"])
        self.assertEqual(net.parameter_count(), 16 + 3 * 16 + 16)
        self.assertEqual(net.note, "a plain attribute")
        self.assertIsInstance(net.body, maps.nn.Linear)
        self.assertEqual(repr(net), "Net(\n  (body): Linear(in_features=3, out_features=16, bias=True)\n)")
        # state_dict shares storage; load_state_dict copies values in.
        state = net.state_dict()
        self.assertEqual(list(state), ["w", "body.weight", "body.bias"])
        doubled = {name: maps.tensor(t.numpy() * 2) for name, t in state.items()}
        net.load_state_dict(doubled)
        np.testing.assert_array_equal(state["w"].numpy(), doubled["w"].numpy())
        np.testing.assert_array_equal(net.w.numpy(), doubled["w"].numpy())
        net.load_state_dict(list(doubled.items()))  # a list of pairs too
        # train / eval / zero_grad / requires_grad_ / to / clone
        self.assertTrue(net.training)
        self.assertIs(net.eval(), net)
        self.assertFalse(net.training or net.body.training)
        net.train()
        self.assertTrue(net.body.training)
        x, y = regression(8)
        maps.mse_loss(net(x), y).backward()
        self.assertIsNotNone(net.w.grad)
        net.zero_grad()
        self.assertTrue(all(p.grad is None for p in net.parameters()))
        net.requires_grad_(False)
        self.assertFalse(any(p.requires_grad for p in net.parameters()))
        net.requires_grad_(True)
        self.assertIs(net.to("float64"), net)
        self.assertEqual({p.dtype for p in net.parameters()}, {"float64"})
        self.assertTrue(net.w.requires_grad and net.w.is_leaf)
        net.to("float32")
        copy = net.body.clone()
        self.assertIsInstance(copy, maps.nn.Linear)
        copy.load_state_dict({n: maps.tensor(np.zeros(t.shape, np.float32)) for n, t in copy.state_dict().items()})
        self.assertTrue(np.any(net.body.weight.numpy() != 0))
        with self.assertRaisesRegex(NotImplementedError, "Net.clone"):
            net.clone()

    def test_registration(self):
        class Registered(maps.nn.Module):
            def __init__(self):
                super().__init__()
                self.scale = self.register_parameter("scale", maps.tensor([2.0], dtype="float32"))
                self.register_buffer("offset", maps.tensor([0.5], dtype="float32"))
                self.register_module("body", maps.nn.MLP([2, 3, 1], "relu"))

            def forward(self, x):
                return self.body(x) * self.scale + self.offset

        module = Registered()
        self.assertTrue(module.scale.requires_grad)
        self.assertEqual([n for n, _ in module.named_parameters()][:1], ["scale"])
        self.assertEqual([n for n, _ in module.named_buffers()], ["offset"])
        self.assertIn("offset", module.state_dict())
        self.assertEqual(module(maps.tensor(np.ones((4, 2), np.float32))).shape, (4, 1))
        module.offset = maps.tensor([1.5], dtype="float32")  # a buffer's new value (same shape)
        self.assertEqual(module.offset.item(), 1.5)
        module.scale = maps.nn.Parameter([3.0], dtype="float32")  # a parameter's slot replaced
        self.assertEqual(module.scale.item(), 3.0)
        with self.assertRaisesRegex(ValueError, "scale"):
            module.scale = maps.nn.Parameter([3.0, 4.0], dtype="float32")
        with self.assertRaisesRegex(ValueError, "already used"):
            module.register_parameter("body", maps.tensor([1.0]))
        with self.assertRaisesRegex(TypeError, "Linear, a C\\+\\+ module, are fixed"):
            maps.nn.Linear(2, 2).register_parameter("extra", maps.tensor([1.0]))
        with self.assertRaisesRegex(TypeError, "cannot assign a int as parameter 'scale'"):
            module.scale = 3
        with self.assertRaisesRegex(ValueError, "Registered.body is a child module already"):
            module.body = maps.nn.Linear(2, 1)

        class Early(maps.nn.Module):
            def __init__(self):
                self.w = maps.nn.Parameter([1.0])
                super().__init__()

        with self.assertRaisesRegex(AttributeError, "before Early.__init__ calls super"):
            Early()

        class NoForward(maps.nn.Module):
            pass

        with self.assertRaisesRegex(NotImplementedError, "NoForward defines no forward"):
            NoForward()(maps.tensor([1.0]))
        with self.assertRaisesRegex(AttributeError, "no attribute 'missing'"):
            module.missing

    def test_a_python_module_lives_on_inside_cpp_containers(self):
        """A Python-defined module that only C++ holds (a Sequential's entry, a child) keeps its Python half."""
        x, _ = regression(4)
        sequential = maps.nn.Sequential(Net(maps.Generator(2)), maps.nn.Tanh())
        parent = maps.nn.ModuleList()
        parent.append(Net(maps.Generator(3)))
        gc.collect()
        self.assertIsInstance(sequential[0], Net)
        self.assertEqual(sequential[0].note, "a plain attribute")
        self.assertEqual(sequential(x).shape, (4, 1))  # C++ Sequential calls the Python forward
        self.assertEqual(parent[0](x).shape, (4, 1))
        self.assertEqual(len(sequential.parameters()), 3)

    def test_a_python_module_trains_with_adam(self):
        """The Python module's parameter and its child Linear's, trained by maps.optim.Adam for 100 steps on a tiny
        regression: the loss falls at least 20-fold (to 1/180 of the first in this build)."""
        x, y = regression()
        net = Net(maps.Generator(0))
        optimizer = maps.optim.Adam(net.parameters(), lr=0.05)
        before = {n: p.numpy() for n, p in net.named_parameters()}
        losses = []
        for _ in range(100):
            optimizer.zero_grad()
            loss = maps.mse_loss(net(x), y)
            loss.backward()
            optimizer.step()
            losses.append(loss.item())
        self.assertLess(losses[-1], losses[0] / 20, f"loss {losses[0]} -> {losses[-1]}")
        for name, p in net.named_parameters():
            self.assertFalse(np.array_equal(p.numpy(), before[name]), name)
        self.assertEqual(optimizer.step_count(0), 100)

    def test_sgd_and_adam_updates(self):
        p = maps.tensor(np.array([1.0, -2.0]), requires_grad=True)
        sgd = maps.optim.SGD([p], lr=0.1, momentum=0.9)
        for _ in range(2):
            sgd.zero_grad()
            maps.sum(p * p).backward()
            sgd.step()
        # buf1 = g1 = 2 p0; p1 = p0 - 0.1 g1; buf2 = 0.9 buf1 + 2 p1; p2 = p1 - 0.1 buf2
        p0 = np.array([1.0, -2.0])
        p1 = p0 - 0.1 * 2 * p0
        np.testing.assert_allclose(p.numpy(), p1 - 0.1 * (0.9 * 2 * p0 + 2 * p1), rtol=1e-12)
        self.assertEqual(sgd.lr, 0.1)
        sgd.lr = 0.01
        self.assertEqual(sgd.lr, 0.01)
        # Adam's first step is lr * sign(g).
        q = maps.tensor(np.array([1.0, -2.0]), requires_grad=True)
        adam = maps.optim.Adam([q], lr=0.1, betas=(0.9, 0.99))
        maps.sum(q * q).backward()
        adam.step()
        np.testing.assert_allclose(q.numpy(), [0.9, -1.9], rtol=1e-6)
        self.assertEqual(adam.betas, (0.9, 0.99))
        with self.assertRaisesRegex(TypeError, "parameter groups"):
            maps.optim.Adam([{"params": [q]}])
        with self.assertRaisesRegex(TypeError, "parameter 1 is a float"):
            maps.optim.SGD([q, 1.0], lr=0.1)
        with self.assertRaisesRegex(ValueError, "learning rate"):
            maps.optim.Adam([q], lr=-1.0)
        self.assertEqual(len(maps.optim.SGD(Net(), lr=0.1).params), 3)  # a module gives its parameters

    def test_adam_state_round_trips(self):
        x, y = regression(16)

        def steps(net, optimizer, n):
            for _ in range(n):
                optimizer.zero_grad()
                maps.mse_loss(net(x), y).backward()
                optimizer.step()

        a = Net(maps.Generator(4))
        adam_a = maps.optim.Adam(a.parameters(), lr=0.01)
        steps(a, adam_a, 3)
        with tempfile.TemporaryDirectory() as folder:
            maps.nn.save(a, pathlib.Path(folder) / "net.ckpt")
            maps.nn.save(adam_a.state_dict(), pathlib.Path(folder) / "adam.ckpt")
            b = Net(maps.Generator(9))
            b.load(pathlib.Path(folder) / "net.ckpt")
            adam_b = maps.optim.Adam(b.parameters(), lr=0.01)
            adam_b.load_state_dict(maps.nn.load(pathlib.Path(folder) / "adam.ckpt"))
        steps(a, adam_a, 2)
        steps(b, adam_b, 2)
        for (name, pa), (_, pb) in zip(a.named_parameters(), b.named_parameters()):
            np.testing.assert_array_equal(pa.numpy(), pb.numpy(), name)
        with self.assertRaisesRegex(ValueError, "Adam state"):
            maps.optim.Adam(Net().parameters()).load_state_dict({"step.0": maps.tensor(1.0)})


class Checkpoints(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.TemporaryDirectory()
        self.path = pathlib.Path(self.folder.name) / "net.ckpt"

    def tearDown(self):
        self.folder.cleanup()

    def test_save_load_round_trip(self):
        net = Net(maps.Generator(6))
        maps.nn.save(net, self.path, config='{"hidden": 16}')
        state, config = maps.nn.load(self.path, with_config=True)
        self.assertEqual(config, '{"hidden": 16}')
        self.assertEqual(list(state), ["w", "body.weight", "body.bias"])
        for name, t in net.state_dict().items():
            np.testing.assert_array_equal(state[name].numpy(), t.numpy(), name)
            self.assertEqual(state[name].dtype, t.dtype)
        other = Net(maps.Generator(7))
        self.assertEqual(other.load(self.path), '{"hidden": 16}')
        x, _ = regression(5)
        np.testing.assert_array_equal(other(x).numpy(), net(x).numpy())
        net.save(self.path)  # the method, and a plain dict of float64 tensors
        maps.nn.save({"a": maps.tensor([[1.0, 2.0]]), "b": np.arange(3.0)}, self.path)
        state = maps.nn.load(str(self.path))
        np.testing.assert_array_equal(state["b"].numpy(), [0.0, 1.0, 2.0])
        self.assertEqual(state["a"].dtype, "float64")

    def test_damaged_and_missing_files_are_refused_naming_them(self):
        net = Net()
        net.save(self.path)
        data = bytearray(self.path.read_bytes())
        data[len(data) // 2] ^= 0xFF
        self.path.write_bytes(bytes(data))
        with self.assertRaisesRegex(RuntimeError, f"{self.path}.*checksum"):
            maps.nn.load(self.path)
        before = net.state_dict()["w"].numpy()
        with self.assertRaisesRegex(RuntimeError, f"{self.path}.*checksum"):
            net.load(self.path)
        np.testing.assert_array_equal(net.w.numpy(), before)
        self.path.write_bytes(bytes(data[:40]))
        with self.assertRaisesRegex(RuntimeError, f"{self.path}.*truncated"):
            maps.nn.load(self.path)
        with self.assertRaisesRegex(FileNotFoundError, "nowhere.ckpt"):
            maps.nn.load(self.path.with_name("nowhere.ckpt"))

    def test_a_state_of_another_module_is_refused_naming_the_entry(self):
        net = Net()
        state = net.state_dict()
        with self.assertRaisesRegex(ValueError, r"Unexpected: bogus"):
            net.load_state_dict({**state, "bogus": maps.tensor([1.0])})
        with self.assertRaisesRegex(ValueError, r"Missing: w\."):
            net.load_state_dict({k: v for k, v in state.items() if k != "w"})
        with self.assertRaisesRegex(ValueError, r"Mismatched: body.weight \(expected \[16, 3\] float32, got \[3, 16\]"):
            net.load_state_dict({**state, "body.weight": maps.tensor(np.zeros((3, 16), np.float32))})
        Net(hidden=8).save(self.path)
        with self.assertRaisesRegex(RuntimeError, f"{self.path}.*Mismatched: w"):
            net.load(self.path)
        with self.assertRaisesRegex(TypeError, "dict or a list"):
            net.load_state_dict(3)


class Runs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.folder = pathlib.Path(WORK) / "run"
        cls.trained = maps.load_run(cls.folder)
        demos = maps.read_demo_file(str(pathlib.Path(WORK) / "gravity.h5")).demos
        cls.obs = np.stack([d.obs[3] for d in demos[:4]])
        cls.tasks = [d.task_index for d in demos[:4]]
        cls.actions = np.stack([d.actions[3] for d in demos[:4]])

    def test_parameters_are_the_policys(self):
        named = self.trained.named_parameters()
        self.assertIn("head_bias", [n for n, _ in named])
        self.assertTrue(all(p.requires_grad and p.is_leaf and p.dtype == "float32" for _, p in named))
        checkpoint = maps.nn.load(self.folder / "best.ckpt")  # the file `maps train` wrote
        for name, p in named:
            np.testing.assert_array_equal(p.numpy(), checkpoint[name].numpy(), name)
        self.assertEqual(self.trained.policy.parameter_count(), sum(p.numpy().size for _, p in named))
        # The tensors are the ones act() computes with: a change through them shows in act().
        before = self.trained.act(self.obs, self.tasks)
        bias = dict(named)["head_bias"]
        saved = bias.numpy()
        self.trained.policy.load_state_dict({**self.trained.policy.state_dict(), "head_bias": maps.tensor(saved + 1)})
        try:
            np.testing.assert_allclose(self.trained.act(self.obs, self.tasks), before + 1, rtol=1e-5, atol=1e-5)
            np.testing.assert_array_equal(bias.numpy(), saved + 1)
        finally:
            self.trained.policy.load_state_dict({**self.trained.policy.state_dict(), "head_bias": maps.tensor(saved)})
        np.testing.assert_array_equal(self.trained.act(self.obs, self.tasks), before)

    def test_forward_is_act_on_the_graph(self):
        out = self.trained.forward(self.obs, self.tasks)
        self.assertTrue(out.requires_grad)
        np.testing.assert_array_equal(out.numpy(), self.trained.act(self.obs, self.tasks))
        np.testing.assert_array_equal(self.trained.forward(maps.tensor(self.obs), self.tasks).numpy(), out.numpy())
        np.testing.assert_array_equal(self.trained.forward(maps.tensor(self.obs[1]), self.tasks[1]).numpy(),
                                      out.numpy()[1])
        with maps.no_grad():
            self.assertFalse(self.trained.forward(self.obs, self.tasks).requires_grad)
        with self.assertRaisesRegex(ValueError, "17"):
            self.trained.forward(maps.tensor(np.zeros((2, 5))), 0)
        with self.assertRaisesRegex(IndexError, r"\[0, 5\)"):
            self.trained.forward(maps.tensor(self.obs), 5)
        with self.assertRaisesRegex(ValueError, "NaN"):
            self.trained.forward(maps.tensor(np.full((1, 17), np.nan)), 0)

    def test_forward_clamps_as_act_does(self):
        """A run on clamped inputs: forward on a tensor (the differentiable path) gives act()'s actions, and an
        observation entry beyond the clamp has no gradient."""
        run = maps.load_run(pathlib.Path(WORK) / "run_clip")
        far = self.obs.copy()
        far[:, 0] += 1e3  # far beyond 0.5 standard deviations of any demonstration state
        observations = maps.tensor(far, requires_grad=True)
        out = run.forward(observations, self.tasks)
        np.testing.assert_array_equal(out.numpy(), run.act(far, self.tasks))
        maps.sum(out * out).backward()
        grad = observations.grad.numpy()
        np.testing.assert_array_equal(grad[:, 0], 0.0)
        self.assertGreater(np.abs(grad).max(), 0.0)  # the entries inside the clamp still get one
        # Moving the clamped entry further changes nothing.
        further = far.copy()
        further[:, 0] += 1e3
        np.testing.assert_array_equal(run.act(further, self.tasks), run.act(far, self.tasks))

    def test_forward_gradient_matches_finite_differences_in_float32(self):
        """d sum(forward) / d head.weight[0, 2, 1] by backward, against a central difference through
        load_state_dict in the float32 policy (loose: float32)."""
        run = maps.load_run(self.folder)
        loss = maps.sum(run.forward(self.obs, self.tasks) ** 2)
        loss.backward()
        weight = run.policy.parameter("head.weight")
        analytic = weight.grad.numpy()[0, 2, 1]
        values = weight.numpy()

        def loss_at(delta):
            changed = values.copy()
            changed[0, 2, 1] += delta
            run.policy.load_state_dict({**run.policy.state_dict(), "head.weight": maps.tensor(changed)})
            with maps.no_grad():
                return float(np.sum(run.forward(self.obs, self.tasks).numpy().astype(np.float64) ** 2))

        h = 1e-2
        numerical = (loss_at(h) - loss_at(-h)) / (2 * h)
        self.assertNotEqual(analytic, 0.0)
        np.testing.assert_allclose(analytic, numerical, rtol=2e-2, atol=1e-3)

    def test_forward_passes_gradcheck_in_float64(self):
        run = maps.load_run(self.folder)
        run.policy.to("float64")
        for name in ("head_bias", "selector.layers.1.bias", "modules1.bias"):
            with self.subTest(parameter=name):
                p = run.policy.parameter(name)
                self.assertEqual(p.dtype, "float64")
                self.assertTrue(maps.gradcheck(lambda _: run.forward(self.obs, self.tasks), [p]))
        observations = maps.tensor(self.obs, requires_grad=True)
        self.assertTrue(maps.gradcheck(lambda o: run.forward(o, self.tasks), [observations]))
        np.testing.assert_allclose(run.act(self.obs, self.tasks), self.trained.act(self.obs, self.tasks), atol=1e-5)

    def test_fine_tuning_a_loaded_run_from_python(self):
        """Adam on the run's parameters, through forward(), lowers its BC error on the demos' actions."""
        run = maps.load_run(self.folder)
        optimizer = maps.optim.Adam(run.parameters(), lr=1e-2)
        target = maps.tensor(self.actions.astype(np.float32))
        losses = []
        for _ in range(20):
            optimizer.zero_grad()
            loss = maps.mse_loss(run.forward(self.obs, self.tasks), target)
            loss.backward()
            optimizer.step()
            losses.append(loss.item())
        self.assertLess(losses[-1], losses[0] / 2, losses)
        error = np.mean((run.act(self.obs, self.tasks) - self.actions) ** 2)
        self.assertLess(error, losses[0] / 2)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit("usage: nn_test.py path/to/maps")
    MAPS = str(pathlib.Path(sys.argv.pop(1)).resolve())
    with tempfile.TemporaryDirectory(prefix="maps-nn-") as work:
        WORK = work
        result = unittest.main(exit=False, verbosity=2).result
    sys.exit(0 if result.wasSuccessful() else 1)
