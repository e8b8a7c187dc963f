#pragma once
#include <pybind11/pybind11.h>

namespace iblbake::py {
void bind_bake(pybind11::module_& m);
void bind_geometry(pybind11::module_& m);
}  // namespace iblbake::py
