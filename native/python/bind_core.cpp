#include "bindings.hpp"

namespace quatcurve::bindings {
void bind_core(pybind11::module_&) {}  // filled in by the foundation issue
}  // namespace quatcurve::bindings
