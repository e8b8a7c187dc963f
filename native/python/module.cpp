// iblbake_core: the Python face of the C++ library. Thin: argument checks
// with the GIL held, then the work with the GIL released.
#include "bindings.h"

#include <exception>

#include "iblbake/bake/bake.h"

PYBIND11_MODULE(iblbake_core, m) {
    m.doc() = "iblbake native core: bake image-based lighting from a lat-long environment (SPEC.md contract 1)";
    m.attr("CONTRACT") = 1;
    m.attr("__version__") = IBLBAKE_VERSION;
    pybind11::register_exception<iblbake::Cancelled>(m, "Cancelled", PyExc_RuntimeError);
    pybind11::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const iblbake::BadInputError& e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        }
    });
    iblbake::py::bind_bake(m);
    iblbake::py::bind_geometry(m);
    iblbake::py::bind_batch(m);
}
