#include <pybind11/pybind11.h>

#include "python/bindings.h"

PYBIND11_MODULE(_maps, m) { maps::python::bind_all(m); }
