#include <pybind11/pybind11.h>

#include "python/bindings.h"

PYBIND11_MODULE(_maps, m) {
  m.doc() = "The maps library's C++ core; use it through the `maps` package (python/maps/__init__.py)";
  maps::python::bind_autograd(m);
  maps::python::bind_envs(m);
  maps::python::bind_demos(m);
  maps::python::bind_runs(m);
}
