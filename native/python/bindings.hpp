// One function per binding file; module.cpp calls them in order. Bindings only bind: they convert
// arrays and call the native library, which holds every formula and every check.
#pragma once

#include <pybind11/pybind11.h>

namespace quatcurve::bindings {
void bind_core(pybind11::module_& m);     // bind_core.cpp: quaternion algebra, matrices, Euler
void bind_curve(pybind11::module_& m);    // bind_curve.cpp: the orientation curve engine
void bind_reduce(pybind11::module_& m);   // bind_reduce.cpp: key reduction
void bind_metrics(pybind11::module_& m);  // bind_metrics.cpp: comparison metrics
void bind_blender_eval(pybind11::module_& m);  // bind_blender_eval.cpp: Blender's F-curve evaluation
void bind_channels(pybind11::module_& m); // bind_channels.cpp: rotation channels, sampling policies
void bind_skeleton(pybind11::module_& m); // bind_skeleton.cpp: skeletons, the distance bound
void bind_clean(pybind11::module_& m);    // bind_clean.cpp: cleaning captured rotations
}  // namespace quatcurve::bindings
