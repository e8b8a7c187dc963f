#pragma once
#include <pybind11/pybind11.h>

#include <string>

#include <nlohmann/json.hpp>

namespace iblbake::py {
void bind_bake(pybind11::module_& m);
void bind_geometry(pybind11::module_& m);
void bind_batch(pybind11::module_& m);

// JSON as Python's json.loads() makes it.
pybind11::object json_to_py(const nlohmann::json& j);
// A path argument: str, os.PathLike or bytes (file system encoding, so a
// name that is not UTF-8 round-trips); anything else is a TypeError.
std::string path_arg(const pybind11::handle& v, const char* what);
}  // namespace iblbake::py
