#include "python/bindings.h"

namespace maps::python {

void bind_all(pybind11::module_& m) {
  m.doc() = "The maps library's C++ core; use it through the `maps` package (python/maps/__init__.py)";
  bind_autograd(m);
  bind_nn(m);
  bind_envs(m);
  bind_demos(m);
  bind_runs(m);
  bind_training(m);  // after bind_nn: SelectorLoss and Policy derive from nn.Module
}

}  // namespace maps::python
