// Bindings of clean.hpp: flips, the noise estimate, spikes, the smoothing within a deviation bound and
// clean_rotations. Arrays in, the native library (without the GIL), arrays out; every check and
// formula lives in native/src/clean.cpp.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "quatcurve/clean.hpp"

namespace quatcurve::bindings {

namespace {

std::vector<Quat> read_quats(py::handle obj, std::size_t n) {
    const Batch b = read_rows(obj, 4, "quats", n);
    std::vector<Quat> q(n);
    for (std::size_t k = 0; k < n; ++k) q[k] = from_wxyz(b.data() + 4 * k);
    return q;
}

DArray quats_array(const std::vector<Quat>& q) {
    DArray out(std::vector<py::ssize_t>{static_cast<py::ssize_t>(q.size()), 4});
    double* p = out.mutable_data();
    for (std::size_t k = 0; k < q.size(); ++k) to_wxyz(q[k], p + 4 * k);
    return out;
}

DArray doubles_array(const std::vector<double>& v) {
    DArray out(static_cast<py::ssize_t>(v.size()));
    std::copy(v.begin(), v.end(), out.mutable_data());
    return out;
}

std::optional<double> optional_number(const py::object& obj) {
    if (obj.is_none()) return std::nullopt;
    return obj.cast<double>();
}

}  // namespace

void bind_clean(py::module_& m) {
    m.def(
        "remove_quat_flips",
        [](py::handle quats) {
            const Batch b = as_batch(quats, {4}, "quats");
            if (b.batch_shape.size() != 1)
                throw py::value_error("quats: expected shape (N, 4), got " + shape_string(b.array));
            std::vector<Quat> q(b.count);
            for (std::size_t k = 0; k < b.count; ++k) q[k] = from_wxyz(b.data() + 4 * k);
            std::size_t flips;
            {
                py::gil_scoped_release release;
                flips = remove_quat_flips(q.data(), q.size());
            }
            return py::make_tuple(quats_array(q), flips);
        },
        py::arg("quats"),
        "(quats, flips): the quaternions (N, 4) (w, x, y, z) with signs made continuous (each negated "
        "where its dot with the one before is negative; every rotation unchanged) and the number of "
        "consecutive pairs repaired.");
    m.def(
        "remove_euler_flips",
        [](py::handle angles, const std::string& order) {
            const EulerOrder o = parse_euler_order(order);
            const Batch b = as_batch(angles, {3}, "angles");
            if (b.batch_shape.size() != 1)
                throw py::value_error("angles: expected shape (N, 3), got " + shape_string(b.array));
            std::vector<Vec3> a(b.count);
            for (std::size_t k = 0; k < b.count; ++k) {
                const double* p = b.data() + 3 * k;
                a[k] = Vec3(p[0], p[1], p[2]);
            }
            std::size_t flips;
            {
                py::gil_scoped_release release;
                flips = remove_euler_flips(a.data(), a.size(), o);
            }
            DArray out(std::vector<py::ssize_t>{static_cast<py::ssize_t>(a.size()), 3});
            double* p = out.mutable_data();
            for (std::size_t k = 0; k < a.size(); ++k) p[3 * k] = a[k].x, p[3 * k + 1] = a[k].y, p[3 * k + 2] = a[k].z;
            return py::make_tuple(out, flips);
        },
        py::arg("angles"), py::arg("order") = "XYZ",
        "(angles, flips): Euler rows (N, 3) (radians about X, Y, Z; Blender's order) each moved to the "
        "equivalent angles nearest the row before (euler_filter: no flips between the two solutions, "
        "no 2 pi jumps; every rotation unchanged) and the number of consecutive pairs repaired.");
    m.def(
        "estimate_rotation_noise",
        [](py::handle times, py::handle quats) {
            const std::vector<double> t = read_times(times);
            const std::vector<Quat> q = read_quats(quats, t.size());
            py::gil_scoped_release release;
            return estimate_rotation_noise(t, q);
        },
        py::arg("times"), py::arg("quats"),
        R"doc(The clip's per-frame rotation noise sigma (radians): the RMS angle by which a frame is off its
true rotation, for white noise. Robust: sqrt(3) * median_i(|r_i| / g_i) / 1.53817, r_i the rotation
vector from the cubic through frame i's two neighbours on each side (at i's time) to frame i, g_i the
prediction's noise gain (sqrt(35/18) on evenly spaced frames). times: (N,) increasing frames; quats: (N, 4) (w, x, y, z), N >= 3.)doc");
    m.def(
        "find_spikes",
        [](py::handle times, py::handle quats, py::object noise, double threshold, std::size_t max_run,
           double min_angle) {
            const std::vector<double> t = read_times(times);
            const std::vector<Quat> q = read_quats(quats, t.size());
            const std::optional<double> given = optional_number(noise);
            SpikeOptions options;
            options.threshold = threshold, options.max_run = max_run, options.min_angle = min_angle;
            Spikes s;
            {
                py::gil_scoped_release release;
                s = find_spikes(t, q, given ? *given : estimate_rotation_noise(t, q), options);
            }
            return py::make_tuple(index_array(s.frames), doubles_array(s.departures));
        },
        py::arg("times"), py::arg("quats"), py::arg("noise") = py::none(), py::kw_only(),
        py::arg("threshold") = SpikeOptions{}.threshold, py::arg("max_run") = SpikeOptions{}.max_run,
        py::arg("min_angle") = SpikeOptions{}.min_angle,
        R"doc((frames, departures): the spike frames (int64 sample indices) and each one's angle (radians) to
the curve through its neighbours. A frame, or a run of up to max_run frames, is a spike when it departs
from what its two nearest non-spike neighbours on each side predict (a cubic in the tangent space of
the nearest; the slerp of the neighbours on a uniform rotation) by more than
max(threshold * noise * g, min_angle) and the motion's own scales there (local noise and speed, the
clip's roughness, a run's inner steps; clean.hpp), g the prediction's noise gain. noise: sigma
(radians); None: estimate_rotation_noise. Best window first, its neighbours scored again, until none
is beyond.)doc");
    m.def(
        "replace_spikes",
        [](py::handle times, py::handle quats, py::handle frames) {
            const std::vector<double> t = read_times(times);
            const std::vector<Quat> q = read_quats(quats, t.size());
            const std::vector<std::size_t> f = read_indices(frames, "frames");
            std::vector<Quat> out;
            {
                py::gil_scoped_release release;
                out = replace_spikes(t, q, f);
            }
            return quats_array(out);
        },
        py::arg("times"), py::arg("quats"), py::arg("frames"),
        "The quaternions (N, 4) with each run of `frames` (increasing sample indices) replaced by the "
        "curve through its neighbours, as find_spikes predicts it; hemisphere-continuous.");

    py::class_<Smoothed>(m, "Smoothed", "The result of smooth_rotations.")
        .def_property_readonly("quats", [](const Smoothed& s) { return quats_array(s.q); },
                               "(N, 4) smoothed rotations (w, x, y, z), hemisphere-continuous")
        .def_readonly("smoothness", &Smoothed::smoothness, "lambda used")
        .def_readonly("max_deviation", &Smoothed::max_deviation,
                      "largest angle (radians) to the input over the bound frames")
        .def_readonly("pulled", &Smoothed::pulled, "frames whose weight the bound raised")
        .def_readonly("kept", &Smoothed::kept, "frames left at their input rotation after the last round");
    m.def(
        "smooth_rotations",
        [](py::handle times, py::handle quats, double deviation, py::object noise, py::object smoothness,
           py::object free_frames) {
            const std::vector<double> t = read_times(times);
            const std::vector<Quat> q = read_quats(quats, t.size());
            SmoothOptions options;
            options.noise = optional_number(noise);
            options.smoothness = optional_number(smoothness);
            if (!free_frames.is_none()) options.free_frames = read_indices(free_frames, "free_frames");
            py::gil_scoped_release release;
            return smooth_rotations(t, q, deviation, options);
        },
        py::arg("times"), py::arg("quats"), py::arg("deviation"), py::kw_only(), py::arg("noise") = py::none(),
        py::arg("smoothness") = py::none(), py::arg("free_frames") = py::none(),
        R"doc(Smoothed rotations within `deviation` (radians, geodesic angle) of quats at every frame not in
free_frames. A Whittaker smoother on the rotation group (weighted squared deviations plus smoothness
times the squared angular acceleration, Gauss-Newton in body-frame rotation vectors, one pentadiagonal
system per step); frames beyond 0.98 * deviation get their weight raised until all are within, and a
frame still beyond after 30 rounds keeps its input rotation. smoothness: lambda; None: the lambda that
minimizes Stein's unbiased estimate of the mean squared angle to the truth for white noise of RMS
angle noise (noise None: estimate_rotation_noise). free_frames: sample indices
(spikes) with no bound and next to no weight. The bound holds at the frames only. Returns a Smoothed.)doc");

    py::class_<CleanResult>(m, "CleanResult", "The result of clean_rotations.")
        .def_property_readonly("quats", [](const CleanResult& r) { return quats_array(r.q); },
                               "(N, 4) cleaned rotations (w, x, y, z), hemisphere-continuous")
        .def_property_readonly("spike_frames", [](const CleanResult& r) { return index_array(r.spike_frames); },
                               "int64 sample indices of the spikes found")
        .def_property_readonly("spike_departures",
                               [](const CleanResult& r) { return doubles_array(r.spike_departures); },
                               "per spike, its angle (radians) to the curve through its neighbours")
        .def_readonly("noise", &CleanResult::noise, "sigma used (radians), estimated or given")
        .def_readonly("deviation", &CleanResult::deviation, "the bound used at the non-spike frames (radians)")
        .def_readonly("max_deviation", &CleanResult::max_deviation,
                      "largest angle (radians) to the input over the non-spike frames")
        .def_readonly("flips", &CleanResult::flips, "quaternion sign flips removed")
        .def_readonly("smoothness", &CleanResult::smoothness, "lambda used (0 when not smoothed)")
        .def_readonly("pulled", &CleanResult::pulled, "frames the bound pulled back")
        .def("__repr__", [](const CleanResult& r) {
            return "<CleanResult " + std::to_string(r.q.size()) + " frames, noise " + std::to_string(r.noise) +
                   " rad, " + std::to_string(r.spike_frames.size()) + " spikes, " + std::to_string(r.flips) +
                   " flips, max_deviation " + std::to_string(r.max_deviation) + " <= " +
                   std::to_string(r.deviation) + " rad>";
        });
    m.def(
        "clean_rotations",
        [](py::handle times, py::handle quats, py::object noise, py::object deviation, double deviation_factor,
           bool spikes, double spike_threshold, std::size_t spike_max_run, double spike_min_angle, bool smooth,
           py::object smoothness) {
            const std::vector<double> t = read_times(times);
            const std::vector<Quat> q = read_quats(quats, t.size());
            CleanOptions options;
            options.noise = optional_number(noise);
            options.deviation = optional_number(deviation);
            options.deviation_factor = deviation_factor;
            options.spikes = spikes;
            options.spike.threshold = spike_threshold;
            options.spike.max_run = spike_max_run;
            options.spike.min_angle = spike_min_angle;
            options.smooth = smooth;
            options.smoothness = optional_number(smoothness);
            py::gil_scoped_release release;
            return clean_rotations(t, q, options);
        },
        py::arg("times"), py::arg("quats"), py::kw_only(), py::arg("noise") = py::none(),
        py::arg("deviation") = py::none(), py::arg("deviation_factor") = CleanOptions{}.deviation_factor,
        py::arg("spikes") = true, py::arg("spike_threshold") = SpikeOptions{}.threshold,
        py::arg("spike_max_run") = SpikeOptions{}.max_run, py::arg("spike_min_angle") = SpikeOptions{}.min_angle,
        py::arg("smooth") = true, py::arg("smoothness") = py::none(),
        R"doc(Clean captured rotations: sign flips removed, the noise estimated (noise=None), spikes found
and replaced by the curve through their neighbours (spikes=True; spike_threshold, spike_max_run,
spike_min_angle as find_spikes' threshold, max_run, min_angle), then smoothed within `deviation`
(radians; None: deviation_factor * noise) of the input at every non-spike frame (smooth=True;
smoothness as smooth_rotations'). times: (N,) increasing frames; quats: (N, 4) (w, x, y, z), N >= 3.
The bound holds at the frames: the result is dense per-frame rotations. Returns a CleanResult (quats,
spike_frames, spike_departures, noise, deviation, max_deviation, flips, smoothness, pulled).)doc");
}

}  // namespace quatcurve::bindings
