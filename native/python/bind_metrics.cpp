#include "bindings.hpp"

namespace quatcurve::bindings {
void bind_metrics(pybind11::module_&) {}  // filled in by the metrics issue
}  // namespace quatcurve::bindings
