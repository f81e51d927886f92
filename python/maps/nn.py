"""The nn layer from Python, after torch.nn: modules (Module, Linear, MLP, Sequential, ModuleList, activations,
MSELoss), Parameter, save/load of checkpoint files (the format `maps train` writes), init and functional.

    import maps

    class Net(maps.nn.Module):
        def __init__(self):
            super().__init__()
            self.body = maps.nn.MLP([3, 16, 1], "tanh")
            self.scale = maps.nn.Parameter([1.0])

        def forward(self, x):
            return self.body(x) * self.scale

    net = Net()
    optimizer = maps.optim.Adam(net.parameters(), lr=1e-2)

docs/python.md, "The nn layer", has the whole tour.
"""

import sys
import types

from . import _maps
from ._maps import Tensor
from ._maps.nn import (  # noqa: F401  (re-exported)
    MLP,
    Identity,
    Linear,
    Module,
    ModuleList,
    ParallelLinear,
    ReLU,
    Sequential,
    Sigmoid,
    Tanh,
    clip_grad_norm_,
    grad_norm,
    init,
    load,
    save,
)

_nn = _maps.nn

__all__ = [
    "Identity", "Linear", "MLP", "MSELoss", "Module", "ModuleList", "ParallelLinear", "Parameter", "ReLU",
    "Sequential", "Sigmoid", "Tanh", "clip_grad_norm_", "functional", "grad_norm", "init", "load", "save", "utils",
]


class Parameter(Tensor):
    """A tensor that a Module registers as a parameter when it is assigned to one of the module's attributes (like
    torch.nn.Parameter): a leaf that requires grad, holding a copy of `data` (a Tensor, numpy array or list)."""

    def __init__(self, data, requires_grad=True, dtype=None):
        super().__init__(data, dtype, requires_grad)


# ----- what Module gets from Python: attribute registration, a Python class's name, repr -----------------------
# Registered parameters, buffers and children live in the C++ module's slots, not in the instance's __dict__:
# attribute reads reach them through __getattr__, so a forward reads the slot's current tensor (after to(),
# load_state_dict() or replace_parameter() too).

_cpp_module_init = _nn.Module.__init__


def _constructed_only(name, method):
    """The C++ method, refused on a module whose __init__ has not run super().__init__() yet (pybind11 would hand
    C++ an unconstructed object)."""

    def call(self, *args, **kwargs):
        if not _nn._is_constructed(self):
            raise RuntimeError(f"{type(self).__name__}.{name}: call super().__init__() first")
        return method(self, *args, **kwargs)

    call.__name__ = name
    call.__doc__ = method.__doc__
    return call


for _name, _member in list(vars(Module).items()):
    if isinstance(_member, property):
        setattr(Module, _name, property(_constructed_only(_name, _member.fget), doc=_member.__doc__))
    elif type(_member).__name__ == "instancemethod" and _name != "__init__":
        setattr(Module, _name, _constructed_only(_name, _member))


def _module_init(self, type_name=None):
    _cpp_module_init(self, type_name or type(self).__name__)


def _own_names(module, what):
    return [name for name, _ in getattr(module, what)(recurse=False)]


def _module_setattr(self, name, value):
    if not _nn._is_constructed(self):
        if isinstance(value, (Module, Parameter)):
            raise AttributeError(f"cannot assign {name!r} before {type(self).__name__}.__init__ calls "
                                 "super().__init__()")
        object.__setattr__(self, name, value)
    elif isinstance(value, Module):
        if any(child == name for child, _ in self.named_children()):
            raise ValueError(f"{type(self).__name__}.{name} is a child module already: a registered child cannot be "
                             "replaced (the C++ slots are fixed); build the module with the child it needs")
        self.__dict__.pop(name, None)
        self.register_module(name, value)
    elif isinstance(value, Tensor) and name in _own_names(self, "named_parameters"):
        self.replace_parameter(name, value)
    elif isinstance(value, Tensor) and name in _own_names(self, "named_buffers"):
        self._set_buffer(name, value)
    elif isinstance(value, Parameter):
        self.__dict__.pop(name, None)
        self.register_parameter(name, value)
    elif name in _own_names(self, "named_parameters"):
        raise TypeError(f"cannot assign a {type(value).__name__} as parameter {name!r} of {type(self).__name__} "
                        "(a maps.Tensor expected)")
    elif any(child == name for child, _ in self.named_children()):
        raise TypeError(f"cannot assign a {type(value).__name__} as child module {name!r} of {type(self).__name__}")
    else:
        object.__setattr__(self, name, value)


def _module_getattr(self, name):
    if name.startswith("__") or not _nn._is_constructed(self):
        raise AttributeError(f"'{type(self).__name__}' object has no attribute '{name}'")
    return self._slot(name)


def _module_forward(self, *args, **kwargs):
    raise NotImplementedError(f"{type(self).__name__} defines no forward")


def _module_repr(self):
    head = f"{self.type_name}({self.extra_repr()}"
    children = self.named_children()
    if not children:
        return head + ")"
    lines = [head]
    for name, child in children:
        lines.append(f"  ({name}): " + repr(child).replace("\n", "\n  "))
    return "\n".join(lines) + "\n)"


def _module_modules(self):
    return [module for _, module in self.named_modules()]


Module.__init__ = _module_init
Module.__setattr__ = _module_setattr
Module.__getattr__ = _module_getattr
Module.forward = _module_forward
Module.__repr__ = _module_repr
Module.modules = _module_modules


def _sequence_iter(self):
    return (self[i] for i in range(len(self)))


Sequential.__iter__ = _sequence_iter
ModuleList.__iter__ = _sequence_iter


class MSELoss(Module):
    """The mean of squared differences (torch.nn.MSELoss with reduction "mean")."""

    def forward(self, prediction, target):
        return _maps.mse_loss(prediction, target)


# ----- maps.nn.functional and maps.nn.utils, importable as modules too ------------------------------------------

functional = types.ModuleType(__name__ + ".functional", "The ops as functions, like torch.nn.functional")
for _name in ("relu", "tanh", "sigmoid", "softplus", "softmax", "log_softmax", "mse_loss", "linear", "one_hot"):
    setattr(functional, _name, getattr(_maps, _name))
utils = types.ModuleType(__name__ + ".utils", "clip_grad_norm_ and grad_norm, like torch.nn.utils")
utils.clip_grad_norm_ = clip_grad_norm_
utils.grad_norm = grad_norm
sys.modules[functional.__name__] = functional
sys.modules[utils.__name__] = utils
sys.modules[__name__ + ".init"] = init
del _name, _member
