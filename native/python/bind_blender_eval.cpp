// Bindings of Blender's F-curve evaluation, emulated (blender_eval.hpp). Bindings only bind: arrays in,
// the native evaluator, an array out; the checks live in check_fcurve_keys.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "quatcurve/blender_eval.hpp"

namespace quatcurve::bindings {

namespace {

// A 1-D array of numbers as a vector.
std::vector<double> read_vector(py::handle obj, const char* name) {
    const Batch b = as_batch(obj, {}, name);
    if (b.batch_shape.size() != 1)
        throw py::value_error(std::string(name) + ": expected a 1-D array, got shape " +
                              shape_string(b.array));
    return std::vector<double>(b.data(), b.data() + b.count);
}

// A (K, 2) array of absolute (frame, value) handles, interleaved.
std::vector<double> read_handles(py::handle obj, const char* name, std::size_t keys) {
    const Batch b = as_batch(obj, {2}, name);
    if (b.batch_shape.size() != 1 || b.count != keys)
        throw py::value_error(std::string(name) + ": expected shape (" + std::to_string(keys) +
                              ", 2) (one (frame, value) per key), got " + shape_string(b.array));
    return std::vector<double>(b.data(), b.data() + 2 * b.count);
}

}  // namespace

void bind_blender_eval(py::module_& m) {
    m.def(
        "blender_evaluate",
        [](py::handle frames, py::handle values, py::handle eval_frames,
           const std::string& interpolation, py::object handle_left, py::object handle_right) {
            const KeyInterpolation ipo = parse_key_interpolation(interpolation);
            FCurveKeys keys;
            keys.frames = read_vector(frames, "frames");
            keys.values = read_vector(values, "values");
            if (ipo == KeyInterpolation::BEZIER) {
                if (handle_left.is_none() || handle_right.is_none())
                    throw py::value_error(std::string(handle_left.is_none() ? "handle_left" : "handle_right") +
                                          ": required for BEZIER (shape (K, 2), absolute (frame, value))");
                keys.handle_left = read_handles(handle_left, "handle_left", keys.frames.size());
                keys.handle_right = read_handles(handle_right, "handle_right", keys.frames.size());
            }
            check_fcurve_keys(keys, ipo);
            const Batch at = as_batch(eval_frames, {}, "eval_frames");
            std::vector<double> f(at.data(), at.data() + at.count);
            for (std::size_t k = 0; k < f.size(); ++k) {
                if (!std::isfinite(f[k]) || !std::isfinite(float(f[k])))
                    throw py::value_error(element_name("eval_frames", at, k) +
                                          ": not a finite float32 frame");
            }
            std::vector<double> out;
            {
                py::gil_scoped_release release;
                blender_evaluate(keys, ipo, f, out);
            }
            DArray result = make_output(at.batch_shape, {});
            std::copy(out.begin(), out.end(), result.mutable_data());
            return result;
        },
        py::arg("frames"), py::arg("values"), py::arg("eval_frames"),
        py::arg("interpolation") = "BEZIER", py::arg("handle_left") = py::none(),
        py::arg("handle_right") = py::none(),
        R"doc(The values Blender shows for an F-curve's keys at `eval_frames` (float64 array, eval_frames' shape).

frames: (K,) key frames, increasing; values: (K,) key values; interpolation: "LINEAR" or "BEZIER"
(every segment); handle_left, handle_right: (K, 2) absolute (frame, value) per key, required for
BEZIER — what keyframe_points' handle_left/handle_right hold after Blender computed them
(fcurve.update()), so any handle type can be emulated. Everything is taken as float32, as Blender
stores it; the result is Blender's float32 arithmetic (fcurve.cc): constant extrapolation, a frame
within 1e-4 of a key gives that key's value, handles longer than their segment are scaled back to
it, the Bezier frame→parameter root in double. No keys give 0 everywhere. F-curve modifiers,
easing, per-key interpolation and cyclic/linear extrapolation are not emulated.

Raises ValueError naming the argument (and element) for wrong shapes, non-finite or beyond-float32
numbers, and frames that are not increasing.)doc");
}

}  // namespace quatcurve::bindings
