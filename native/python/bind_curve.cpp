#include "bindings.hpp"

namespace quatcurve::bindings {
void bind_curve(pybind11::module_&) {}  // filled in by the curve issue
}  // namespace quatcurve::bindings
