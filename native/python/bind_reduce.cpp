#include "bindings.hpp"

namespace quatcurve::bindings {
void bind_reduce(pybind11::module_&) {}  // filled in by the reduce issue
}  // namespace quatcurve::bindings
