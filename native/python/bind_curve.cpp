// quatcurve.Curve: the orientation curve engine (native/include/quatcurve/curve.hpp).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <deque>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "quatcurve/bake.hpp"
#include "quatcurve/channels.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/fit.hpp"

namespace quatcurve::bindings {

namespace {

std::vector<double> key_times(py::handle obj) {
    const Batch b = as_batch(obj, {}, "times");
    if (b.batch_shape.size() != 1) throw py::value_error("times: expected shape (K,), got " + shape_string(b.array));
    return std::vector<double>(b.data(), b.data() + b.count);
}

// A (K, n) array of keys as K vectors of n doubles each.
Batch key_rows(py::handle obj, py::ssize_t n, const char* name) {
    Batch b = as_batch(obj, {n}, name);
    if (b.batch_shape.size() != 1)
        throw py::value_error(std::string(name) + ": expected shape (K, " + std::to_string(n) + "), got " +
                              shape_string(b.array));
    return b;
}

// **options → CurveOptions; names and values are checked by quatcurve::set_option.
CurveOptions to_options(Method method, const py::kwargs& kwargs) {
    CurveOptions options;
    for (const auto& item : kwargs) {
        const std::string name = py::str(item.first);
        std::vector<double> values;
        if (py::isinstance<py::bool_>(item.second)) {
            values.push_back(item.second.cast<bool>() ? 1.0 : 0.0);
        } else {
            const Batch b = as_batch(item.second, {}, name.c_str());
            if (b.batch_shape.size() > 1)
                throw py::value_error(name + ": expected a number or a 1-D array, got shape " + shape_string(b.array));
            values.assign(b.data(), b.data() + b.count);
        }
        set_option(options, method, name, values);
    }
    return options;
}

py::object per_key_value(const std::vector<double>& v) {
    if (v.size() == 1) return py::float_(v[0]);
    DArray a(static_cast<py::ssize_t>(v.size()));
    std::copy(v.begin(), v.end(), a.mutable_data());
    return std::move(a);
}

py::dict options_dict(const Curve& c) {
    py::dict d;
    const CurveOptions& o = c.options();
    for (const std::string& name : option_names(c.method())) {
        if (name == "shortest_path") d["shortest_path"] = o.shortest_path;
        else if (name == "clamped") d["clamped"] = o.clamped;
        else if (name == "tension") d["tension"] = per_key_value(o.tension);
        else if (name == "continuity") d["continuity"] = per_key_value(o.continuity);
        else if (name == "bias") d["bias"] = per_key_value(o.bias);
        else if (name == "ease_in") d["ease_in"] = per_key_value(o.ease_in);
        else if (name == "ease_out") d["ease_out"] = per_key_value(o.ease_out);
        else if (name == "turns") d["turns"] = per_key_value(o.turns);
        else if (name == "cyclic") d["cyclic"] = o.cyclic;
    }
    return d;
}

// Curve::path_rule_breaks as a (B, 3) array: key segment index, keyed arc, sampled path length.
DArray breaks_array(const std::vector<std::pair<std::size_t, SegmentPath>>& breaks) {
    DArray a({static_cast<py::ssize_t>(breaks.size()), py::ssize_t(3)});
    for (std::size_t i = 0; i < breaks.size(); ++i) {
        a.mutable_data()[3 * i] = static_cast<double>(breaks[i].first);
        a.mutable_data()[3 * i + 1] = breaks[i].second.arc;
        a.mutable_data()[3 * i + 2] = breaks[i].second.length;
    }
    return a;
}

DArray read_only(DArray a) {
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    return a;
}

// Key frames (K,) and K rows of channel_count(mode) values, as a job keeps them (BakeJob, FitJob).
void mode_keys(py::handle times, py::handle values, const RotationMode& mode, const char* name,
               std::vector<double>& t, std::vector<double>& v) {
    t = key_times(times);
    const Batch rows = key_rows(values, static_cast<py::ssize_t>(channel_count(mode)), name);
    v.assign(rows.data(), rows.data() + rows.count * channel_count(mode));
}

// fit_channels' arguments as a FitJob (fit_channels and FitQueue.push).
FitJob fit_job(py::handle key_frames, py::handle key_values, const std::string& mode_name, const std::string& method,
               int subframes, double tolerance, double min_gap, const KeyFit* previous, const py::kwargs& kwargs) {
    FitJob j;
    j.mode = parse_rotation_mode(mode_name);
    j.method = parse_method(method);
    j.options = to_options(j.method, kwargs);
    mode_keys(key_frames, key_values, j.mode, "key_values", j.key_frames, j.key_values);
    j.subframes = subframes;
    j.tolerance = tolerance;
    j.min_gap = min_gap;
    j.previous = previous;
    return j;
}

// A FitQueue and the Python objects of its jobs' `previous` fits, kept until each job is taken
// (declared first: released after the queue has joined its workers).
struct PyFitQueue {
    PyFitQueue(std::size_t threads, std::size_t window) : queue(threads, window) {}
    std::deque<py::object> previous;
    FitQueue queue;
};

}  // namespace

void bind_curve(py::module_& m) {
    py::tuple names(method_names().size());
    for (std::size_t i = 0; i < method_names().size(); ++i) names[i] = method_names()[i];
    m.attr("METHODS") = names;
    // Each method's option names (curve.hpp option_names): what the add-on's settings pass on.
    py::dict method_options;
    for (const std::string& name : method_names()) {
        const std::vector<std::string> options = option_names(parse_method(name));
        py::tuple t(options.size());
        for (std::size_t i = 0; i < options.size(); ++i) t[i] = options[i];
        method_options[py::str(name)] = t;
    }
    m.attr("METHOD_OPTIONS") = method_options;
    m.def("cpu_level", &cpu_level,
          "The version of the hot samplers this process runs: 4 (x86-64-v4, AVX-512), 3 (x86-64-v3, AVX2 "
          "and FMA) or 0 (baseline; arm64). QUATCURVE_CPU_LEVEL=0 or 3 in the environment caps it.");
    m.attr("PATH_RULE_FACTOR") = kPathRuleFactor;
    m.attr("PATH_RULE_SLACK") = kPathRuleSlack;

    py::class_<Curve>(m, "Curve",
                      "Orientation curve through keys (times in frames, quaternions w, x, y, z).\n\n"
                      "Curve(times, quats, method='SLERP', **options); Curve.from_euler(times, angles, "
                      "order='XYZ', method='SLERP', **options); "
                      "Curve.from_axis_angle(times, values, method='SLERP', **options).\nMethods: METHODS. Options: shortest_path "
                      "(SLERP, bool); clamped (SQUAD, TCB, CATMULL_ROM, bool, default True: overshoot-free "
                      "tangents; False: the textbook ones); ease_in, ease_out in [0, 1] (every method, a number or one per "
                      "key: slows into / out of keys, path unchanged); turns (every method but EULER and QUAT_COMPONENTS, whole "
                      "numbers, a number or one per key: extra signed full turns of the segment leaving each key "
                      "about its own axis); tension, continuity, bias in [-1, 1] (TCB; a "
                      "number or one per key); cyclic (every method, bool: a loop whose last key is the first "
                      "rotation one period later; sampled modulo the period).\nsample(times) -> (..., 4), angular_velocity(times) -> "
                      "(..., 3) in rad/frame, world frame; constant outside the keys.")
        .def(py::init([](py::handle times, py::handle quats, const std::string& method, const py::kwargs& kwargs) {
                 const Method meth = parse_method(method);
                 CurveOptions options = to_options(meth, kwargs);
                 std::vector<double> t = key_times(times);
                 const Batch q = key_rows(quats, 4, "quats");
                 std::vector<Quat> keys(q.count);
                 for (std::size_t i = 0; i < q.count; ++i) keys[i] = from_wxyz(q.data() + 4 * i);
                 // Building the tangents is most of a bake's native work: let other targets' threads run.
                 py::gil_scoped_release release;
                 return Curve(std::move(t), keys, meth, std::move(options));
             }),
             py::arg("times"), py::arg("quats"), py::arg("method") = "SLERP")
        .def_static(
            "from_euler",
            [](py::handle times, py::handle angles, const std::string& order, const std::string& method,
               const py::kwargs& kwargs) {
                const Method meth = parse_method(method);
                const EulerOrder ord = parse_euler_order(order);
                CurveOptions options = to_options(meth, kwargs);
                std::vector<double> t = key_times(times);
                const Batch a = key_rows(angles, 3, "angles");
                std::vector<Vec3> keys(a.count);
                for (std::size_t i = 0; i < a.count; ++i)
                    keys[i] = Vec3(a.data()[3 * i], a.data()[3 * i + 1], a.data()[3 * i + 2]);
                py::gil_scoped_release release;
                return Curve::from_euler(std::move(t), keys, ord, meth, std::move(options));
            },
            py::arg("times"), py::arg("angles"), py::arg("order") = "XYZ", py::arg("method") = "SLERP",
            "Keys from Euler angles (radians, (ax, ay, az) in Blender's order semantics); every segment keeps "
            "the turn of its Euler path (spins survive).")
        .def_static(
            "from_axis_angle",
            [](py::handle times, py::handle values, const std::string& method, const py::kwargs& kwargs) {
                const Method meth = parse_method(method);
                CurveOptions options = to_options(meth, kwargs);
                std::vector<double> t = key_times(times);
                const Batch a = key_rows(values, 4, "values");
                std::vector<double> keys(a.data(), a.data() + 4 * a.count);
                py::gil_scoped_release release;
                return Curve::from_axis_angle(std::move(t), keys, meth, std::move(options));
            },
            py::arg("times"), py::arg("values"), py::arg("method") = "SLERP",
            "Keys from Blender axis-angle channels (K, 4) (angle in radians, axis x, y, z; the axis is "
            "normalized, a zero axis refused); every segment keeps the turn of its axis-angle path (spins "
            "over 360° survive).")
        .def_static(
            "from_channels",
            [](py::handle times, py::handle values, const std::string& mode_name, const std::string& method,
               const py::kwargs& kwargs) {
                const RotationMode mode = parse_rotation_mode(mode_name);
                const Method meth = parse_method(method);
                CurveOptions options = to_options(meth, kwargs);
                std::vector<double> t = key_times(times);
                const Batch v = key_rows(values, static_cast<py::ssize_t>(channel_count(mode)), "values");
                std::vector<double> keys(v.data(), v.data() + v.count * channel_count(mode));
                py::gil_scoped_release release;
                return curve_from_channels(t, keys, mode, meth, options);
            },
            py::arg("times"), py::arg("values"), py::arg("mode"), py::arg("method") = "SLERP",
            "Keys as Blender's rotation channels of `mode` ('QUATERNION' (K, 4) w, x, y, z as stored; an Euler "
            "order (K, 3); 'AXIS_ANGLE' (K, 4)): the Curve constructor, from_euler or from_axis_angle, so "
            "Euler and axis-angle spins survive. The one way the add-on builds a curve through keys.")
        .def(
            "sample",
            [](const Curve& c, py::handle times) {
                const Batch t = as_batch(times, {}, "times");
                DArray out = make_output(t.batch_shape, {4});
                double* o = out.mutable_data();
                {
                    py::gil_scoped_release release;
                    c.sample(t.data(), t.count, o);
                }
                return out;
            },
            py::arg("times"), "Orientations (w, x, y, z) at the given frames, shape times.shape + (4,).")
        .def(
            "sample_keys",
            [](const Curve& c, py::handle frames, const std::string& mode_name, py::object reference) {
                const RotationMode mode = parse_rotation_mode(mode_name);
                const std::size_t nc = channel_count(mode);
                const Batch t = as_batch(frames, {}, "frames");
                if (t.batch_shape.size() != 1)
                    throw py::value_error("frames: expected shape (N,), got " + shape_string(t.array));
                Batch ref;
                std::size_t rows = 0;
                if (!reference.is_none()) {
                    ref = as_batch(reference, {static_cast<py::ssize_t>(nc)}, "reference");
                    if (ref.batch_shape.size() > 1)
                        throw py::value_error("reference: expected one row, or one per frame, got " +
                                              shape_string(ref.array));
                    rows = ref.batch_shape.empty() ? 1 : ref.count;
                }
                const std::size_t n = t.count;
                py::array_t<float> out(std::vector<py::ssize_t>{static_cast<py::ssize_t>(nc),
                                                                static_cast<py::ssize_t>(n), 2});
                float* o = out.mutable_data();
                bool finite = true;
                {
                    // One call, one release of the GIL, for a bake's whole per-target native work
                    // after the curve: its worker thread then waits for the GIL twice per target,
                    // not at every step, while the main thread writes keys.
                    py::gil_scoped_release release;
                    finite = sample_channel_keys(c, t.data(), n, mode, rows ? ref.data() : nullptr, rows, o);
                }
                if (!finite) throw py::value_error("the curve gave non-finite channel values");
                return out;
            },
            py::arg("frames"), py::arg("mode"), py::arg("reference") = py::none(),
            "The curve sampled at frames (N,) as the F-curve keys of rotation mode `mode`: (C, N, 2) "
            "float32, per channel the (frame, value) pairs as Blender stores keys "
            "(keyframe_points.foreach_set('co', keys[c].ravel())); the values are "
            "quats_to_channels(sample(frames), mode, reference) rounded to float32 (so continuous along "
            "the frames). Non-finite values (a value beyond float32's range) raise ValueError.")
        .def(
            "angular_velocity",
            [](const Curve& c, py::handle times) {
                const Batch t = as_batch(times, {}, "times");
                DArray out = make_output(t.batch_shape, {3});
                double* o = out.mutable_data();
                {
                    py::gil_scoped_release release;
                    c.angular_velocity(t.data(), t.count, o);
                }
                return out;
            },
            py::arg("times"), "World-frame angular velocity (rad/frame), exact, shape times.shape + (3,).")
        .def(
            "segment_paths",
            [](const Curve& c, std::size_t samples_per_segment) {
                std::vector<SegmentPath> p;
                {
                    py::gil_scoped_release release;
                    p = c.segment_paths(samples_per_segment);
                }
                DArray a({static_cast<py::ssize_t>(p.size()), py::ssize_t(2)});
                for (std::size_t i = 0; i < p.size(); ++i) {
                    a.mutable_data()[2 * i] = p[i].arc;
                    a.mutable_data()[2 * i + 1] = p[i].length;
                }
                return a;
            },
            py::arg("samples_per_segment") = 64,
            "Per key segment (K-1, 2): the keyed arc and the sampled path length (radians). The path rule: "
            "length <= PATH_RULE_FACTOR * arc + PATH_RULE_SLACK.")
        .def(
            "corner_times",
            [](const Curve& c) {
                const std::vector<double> t = c.corner_times();
                py::array_t<double> out(static_cast<py::ssize_t>(t.size()));
                std::copy(t.begin(), t.end(), out.mutable_data());
                return out;
            },
            "Times where the curve may turn a corner (float64, sorted): the keys and the sub-keys of segments "
            "split for turning more than 180 degrees, through the ease warp.")
        .def(
            "motion_bounds",
            [](const Curve& c, double t0, double t1) {
                double speed, accel;
                c.motion_bounds(t0, t1, speed, accel);
                return py::make_tuple(speed, accel);
            },
            py::arg("t0"), py::arg("t1"),
            "(speed, accel): upper bounds at every time in [t0, t1] of the angular speed (radians per frame) "
            "and of the unit quaternion's second derivative |q''| (per frame squared), between corner_times; "
            "inf where none is known.")
        .def(
            "path_rule_breaks",
            [](const Curve& c) {
                std::vector<std::pair<std::size_t, SegmentPath>> b;
                {
                    py::gil_scoped_release release;
                    b = c.path_rule_breaks();
                }
                return breaks_array(b);
            },
            "(B, 3): key segment index, keyed arc and sampled path length (radians) of every key segment "
            "whose segment_paths() length breaks the path rule; nothing is sampled where the curve's "
            "construction settled it (SLERP, NLERP, and the clamped SQUAD, TCB, CATMULL_ROM).")
        .def_property_readonly("times",
                               [](const Curve& c) {
                                   const auto& t = c.times();
                                   DArray a(static_cast<py::ssize_t>(t.size()));
                                   std::copy(t.begin(), t.end(), a.mutable_data());
                                   return read_only(std::move(a));
                               })
        .def_property_readonly("quats",
                               [](const Curve& c) {
                                   const auto& q = c.quats();
                                   DArray a({static_cast<py::ssize_t>(q.size()), py::ssize_t(4)});
                                   for (std::size_t i = 0; i < q.size(); ++i) to_wxyz(q[i], a.mutable_data() + 4 * i);
                                   return read_only(std::move(a));
                               })
        .def_property_readonly("method", [](const Curve& c) { return std::string(method_name(c.method())); })
        .def_property_readonly("options", &options_dict)
        .def("__repr__", [](const Curve& c) {
            std::string s = "quatcurve.Curve(method='" + std::string(method_name(c.method())) +
                            "', keys=" + std::to_string(c.times().size());
            if (c.has_euler_keys()) s += ", euler_order='" + std::string(euler_order_name(c.euler_order())) + "'";
            s += ", frames=[" + py::repr(py::float_(c.times().front())).cast<std::string>() + ", " +
                 py::repr(py::float_(c.times().back())).cast<std::string>() + "]";
            for (const auto& item : options_dict(c))
                s += ", " + py::str(item.first).cast<std::string>() + "=" + py::repr(item.second).cast<std::string>();
            return s + ")";
        });

    py::class_<BakeJob>(m, "BakeJob",
                        "One target of a BakeQueue: BakeJob(times, values, keys_mode, method, mode, reference=None, "
                        "**options) — the curve of `method` through keys (times (K,), values (K, C) channel values of "
                        "rotation mode `keys_mode`: Curve, Curve.from_euler or Curve.from_axis_angle) with the "
                        "curve's options, sampled as the keys of rotation mode `mode` with `reference` as "
                        "Curve.sample_keys takes it.")
        .def(py::init([](py::handle times, py::handle values, const std::string& keys_mode, const std::string& method,
                         const std::string& mode, py::object reference, const py::kwargs& kwargs) {
                 BakeJob job;
                 job.keys_mode = parse_rotation_mode(keys_mode);
                 job.method = parse_method(method);
                 job.output = parse_rotation_mode(mode);
                 job.options = to_options(job.method, kwargs);
                 mode_keys(times, values, job.keys_mode, "values", job.times, job.values);
                 if (!reference.is_none()) {
                     const std::size_t nc = channel_count(job.output);
                     const Batch ref = as_batch(reference, {static_cast<py::ssize_t>(nc)}, "reference");
                     if (ref.batch_shape.size() > 1)
                         throw py::value_error("reference: expected one row, or one per frame, got " +
                                               shape_string(ref.array));
                     job.reference_rows = ref.batch_shape.empty() ? 1 : ref.count;
                     job.reference.assign(ref.data(), ref.data() + nc * job.reference_rows);
                 }
                 return job;
             }),
             py::arg("times"), py::arg("values"), py::arg("keys_mode"), py::arg("method"), py::arg("mode"),
             py::arg("reference") = py::none());

    py::class_<BakeQueue>(m, "BakeQueue",
                          "BakeQueue(frames, jobs, threads=0, window=8): the jobs (BakeJob) run on `threads` native "
                          "worker threads (0: each when it is taken), at most `window` finished ahead of the "
                          "taker, and are taken in order by iterating: each gives (keys, breaks) — keys the "
                          "(C, N, 2) float32 of Curve.sample_keys(frames, mode, reference), breaks the (B, 3) of "
                          "Curve.path_rule_breaks(). The same results bit for bit whatever the thread count; a "
                          "job's error (ValueError) is raised when it is taken. The workers never need the GIL, "
                          "so the taker may hold it (writing keys) while they run.")
        .def(py::init([](py::handle frames, const py::sequence& job_list, std::size_t threads, std::size_t window) {
                 std::vector<BakeJob> jobs;
                 jobs.reserve(py::len(job_list));
                 for (const py::handle job : job_list) {
                     if (!py::isinstance<BakeJob>(job))
                         throw py::type_error("jobs[" + std::to_string(jobs.size()) +
                                              "]: expected a quatcurve.BakeJob, got " +
                                              py::str(py::type::of(job).attr("__name__")).cast<std::string>());
                     jobs.push_back(job.cast<const BakeJob&>());
                 }
                 const Batch f = as_batch(frames, {}, "frames");
                 if (f.batch_shape.size() != 1)
                     throw py::value_error("frames: expected shape (N,), got " + shape_string(f.array));
                 return std::make_unique<BakeQueue>(std::vector<double>(f.data(), f.data() + f.count),
                                                    std::move(jobs), threads, window);
             }),
             py::arg("frames"), py::arg("jobs"), py::arg("threads") = 0, py::arg("window") = 8)
        .def("__len__", &BakeQueue::size)
        .def_property_readonly("remaining", &BakeQueue::remaining)
        .def("__iter__", [](py::object self) { return self; })
        .def("__next__", [](BakeQueue& q) {
            if (q.remaining() == 0) throw py::stop_iteration();
            BakedKeys baked;
            {
                py::gil_scoped_release release;
                baked = q.next();
            }
            const auto n = static_cast<py::ssize_t>(baked.channels ? baked.keys.size() / (2 * baked.channels) : 0);
            auto* owned = new std::vector<float>(std::move(baked.keys));
            py::capsule owner(owned, [](void* p) { delete static_cast<std::vector<float>*>(p); });
            py::array_t<float> keys({static_cast<py::ssize_t>(baked.channels), n, py::ssize_t(2)}, owned->data(),
                                    owner);
            return py::make_tuple(std::move(keys), breaks_array(baked.path_rule_breaks));
        });

    m.def(
        "fit_channels",
        [](py::handle key_frames, py::handle key_values, const std::string& mode, const std::string& method,
           int subframes, double tolerance, double min_gap, const KeyFit* previous, const py::kwargs& kwargs) {
            const FitJob j = fit_job(key_frames, key_values, mode, method, subframes, tolerance, min_gap, previous, kwargs);
            py::gil_scoped_release release;
            return fit_channels(j.key_frames, j.key_values, j.mode, j.method, j.options, j.subframes, j.tolerance,
                                j.min_gap, j.previous);
        },
        py::arg("key_frames"), py::arg("key_values"), py::arg("mode"), py::arg("method"), py::kw_only(),
        py::arg("subframes"), py::arg("tolerance"), py::arg("min_gap") = 0.01, py::arg("previous") = nullptr,
        "A target's whole fit in one call without the GIL: Curve.from_channels(key_frames, key_values, mode, "
        "method, **options), quaternion keys given the sign the curve reaches them with, then "
        "fit_through_keys(curve, key_frames, those keys, mode, subframes=, tolerance=, min_gap=, previous=). "
        "A KeyFit; its curve and key_values are the curve and the keys as the fit writes them.");

    py::class_<PyFitQueue>(m, "FitQueue",
                           "FitQueue(threads=0, window=1024): fit_channels of each job pushed (push takes "
                           "fit_channels' arguments), run on `threads` native worker threads (0: each when it is "
                           "taken), at most `window` finished ahead of the taker, taken in push order by "
                           "iterating after close(): each gives a KeyFit. The same results bit for bit whatever "
                           "the thread count; a job's error (ValueError) is raised when it is taken. The workers "
                           "never need the GIL, so the taker may hold it (reading the next targets, writing "
                           "keys) while they run; a job's `previous` is kept alive until it is taken.")
        .def(py::init([](std::size_t threads, std::size_t window) { return std::make_unique<PyFitQueue>(threads, window); }),
             py::arg("threads") = 0, py::arg("window") = 1024)
        .def(
            "push",
            [](PyFitQueue& q, py::handle key_frames, py::handle key_values, const std::string& mode,
               const std::string& method, int subframes, double tolerance, double min_gap, py::object previous,
               const py::kwargs& kwargs) {
                if (!previous.is_none() && !py::isinstance<KeyFit>(previous))
                    throw py::type_error("previous: expected a quatcurve.KeyFit or None, got " +
                                         py::str(py::type::of(previous).attr("__name__")).cast<std::string>());
                const KeyFit* prev = previous.is_none() ? nullptr : &previous.cast<const KeyFit&>();
                FitJob job = fit_job(key_frames, key_values, mode, method, subframes, tolerance, min_gap, prev, kwargs);
                q.queue.push(std::move(job));
                q.previous.push_back(std::move(previous));
            },
            py::arg("key_frames"), py::arg("key_values"), py::arg("mode"), py::arg("method"), py::kw_only(),
            py::arg("subframes"), py::arg("tolerance"), py::arg("min_gap") = 0.01, py::arg("previous") = py::none(),
            "Adds a job: fit_channels' arguments (checked now: a bad argument raises here, a fit's own error when "
            "the job is taken).")
        .def("close", [](PyFitQueue& q) { q.queue.close(); }, "No more jobs: iterating ends after the last one.")
        .def("__len__", [](const PyFitQueue& q) { return q.queue.size(); })
        .def_property_readonly("remaining", [](const PyFitQueue& q) { return q.queue.remaining(); })
        .def("__iter__", [](py::object self) { return self; })
        .def("__next__", [](PyFitQueue& q) {
            if (q.queue.remaining() == 0) throw py::stop_iteration();
            py::object previous = std::move(q.previous.front());  // released once its job is done
            q.previous.pop_front();
            py::gil_scoped_release release;
            return q.queue.next();
        });
}

}  // namespace quatcurve::bindings
