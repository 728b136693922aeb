// The Python module `quatcurve`. InvalidArgument from the native library becomes ValueError.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "quatcurve/errors.hpp"
#include "quatcurve/version.hpp"

PYBIND11_MODULE(quatcurve, m) {
    m.doc() = "Orientation interpolation curves on the unit quaternion sphere (native core of quatcurve).";
    m.attr("__version__") = quatcurve::kVersion;
    pybind11::register_local_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const quatcurve::InvalidArgument& e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        }
    });
    quatcurve::bindings::bind_core(m);
    quatcurve::bindings::bind_curve(m);
    quatcurve::bindings::bind_reduce(m);
    quatcurve::bindings::bind_metrics(m);
    quatcurve::bindings::bind_blender_eval(m);
    quatcurve::bindings::bind_channels(m);
    quatcurve::bindings::bind_skeleton(m);
    quatcurve::bindings::bind_clean(m);
}
