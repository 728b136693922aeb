// Python bindings of metrics.hpp: path metrics over sampled orientation paths (radians, frames).
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "quatcurve/metrics.hpp"

namespace quatcurve::bindings {

namespace {

// A path argument: shape (N, 4) quaternions (w, x, y, z), (N, 3) vectors, or (N,) numbers.
Batch path_batch(py::handle obj, std::initializer_list<py::ssize_t> tail, const char* name) {
    Batch b = as_batch(obj, tail, name);
    if (b.batch_shape.size() != 1) {
        std::string want = "(N";
        for (py::ssize_t t : tail) want += ", " + std::to_string(t);
        want += tail.size() == 0 ? ",)" : ")";
        throw py::value_error(std::string(name) + ": expected shape " + want + ", got " +
                              shape_string(b.array));
    }
    return b;
}

std::vector<Quat> to_quats(py::handle obj, const char* name) {
    const Batch b = path_batch(obj, {4}, name);
    std::vector<Quat> out(b.count);
    for (std::size_t i = 0; i < b.count; ++i) out[i] = from_wxyz(b.data() + 4 * i);
    return out;
}

std::vector<Vec3> to_vec3s(py::handle obj, const char* name) {
    const Batch b = path_batch(obj, {3}, name);
    std::vector<Vec3> out(b.count);
    for (std::size_t i = 0; i < b.count; ++i) {
        const double* p = b.data() + 3 * i;
        out[i] = Vec3(p[0], p[1], p[2]);
    }
    return out;
}

std::vector<double> to_doubles(py::handle obj, const char* name) {
    const Batch b = path_batch(obj, {}, name);
    return std::vector<double>(b.data(), b.data() + b.count);
}

DArray to_array(const std::vector<double>& v) {
    DArray out(static_cast<py::ssize_t>(v.size()));
    std::copy(v.begin(), v.end(), out.mutable_data());
    return out;
}

}  // namespace

void bind_metrics(py::module_& m) {
    m.def(
        "angular_deviation",
        [](py::handle quats, py::handle reference) {
            return to_array(angular_deviation(to_quats(quats, "quats"), to_quats(reference, "reference")));
        },
        py::arg("quats"), py::arg("reference"),
        "Geodesic angle (radians, sign-invariant) between quats[i] and reference[i]; both (N, 4) "
        "(w, x, y, z). Returns (N,).");

    m.def(
        "interval_speeds",
        [](py::handle times, py::handle quats) {
            return to_array(interval_speeds(to_doubles(times, "times"), to_quats(quats, "quats")));
        },
        py::arg("times"), py::arg("quats"),
        "Mean angular speed (radians per frame) over each sampling interval: angle(q[i], q[i+1]) / "
        "(t[i+1] - t[i]). times (N,) increasing, quats (N, 4). Returns (N-1,); the value belongs to the "
        "interval's midpoint.");

    m.def(
        "segment_speed_ratios",
        [](py::handle times, py::handle quats, py::handle key_times) {
            return to_array(segment_speed_ratios(to_doubles(times, "times"), to_quats(quats, "quats"),
                                                 to_doubles(key_times, "key_times")));
        },
        py::arg("times"), py::arg("quats"), py::arg("key_times"),
        "Per segment between consecutive key times (which must be sample times): max/min of the "
        "interval speeds inside it. 1.0 = constant speed; inf when the speed reaches 0 while moving. "
        "Returns (K-1,).");

    m.def(
        "segment_speed_ratios_from_velocity",
        [](py::handle times, py::handle velocities, py::handle key_times) {
            return to_array(segment_speed_ratios_from_velocity(to_doubles(times, "times"),
                                                               to_vec3s(velocities, "velocities"),
                                                               to_doubles(key_times, "key_times")));
        },
        py::arg("times"), py::arg("velocities"), py::arg("key_times"),
        "Per segment: max/min of |velocities[i]| (N, 3) over the samples strictly inside it; NaN for a "
        "segment without such samples. Returns (K-1,).");

    m.def(
        "path_length", [](py::handle quats) { return path_length(to_quats(quats, "quats")); },
        py::arg("quats"),
        "Sum of geodesic angles between consecutive quats (N, 4), radians. Of the key orientations: the "
        "sum of key-to-key geodesic angles.");

    m.def(
        "key_jumps",
        [](py::handle times, py::handle quats, py::handle key_times) {
            const KeyJumps j = key_jumps(to_doubles(times, "times"), to_quats(quats, "quats"),
                                         to_doubles(key_times, "key_times"));
            return py::make_tuple(to_array(j.velocity), to_array(j.acceleration));
        },
        py::arg("times"), py::arg("quats"), py::arg("key_times"),
        "(velocity_jumps, acceleration_jumps), each (K,): |w+ - w-| (radians/frame) and |a+ - a-| "
        "(radians/frame^2) at each key, from one-sided fits of the samples on each side; NaN at the "
        "first and last key and where a side has too few samples.");

    m.def(
        "gimbal_distances",
        [](py::handle angles, const std::string& order) {
            return to_array(gimbal_distances(to_vec3s(angles, "angles"), parse_euler_order(order)));
        },
        py::arg("angles"), py::arg("order"),
        "Distance (radians) of the order's middle angle from gimbal lock per sample; angles (N, 3) as "
        "Blender's rotation_euler (about X, Y, Z).");

    m.def(
        "gimbal_distances_from_quats",
        [](py::handle quats, const std::string& order) {
            const std::vector<Quat> q = to_quats(quats, "quats");
            const EulerOrder o = parse_euler_order(order);
            std::vector<double> d;
            {
                py::gil_scoped_release release;
                d = gimbal_distances(q, o);
            }
            return to_array(d);
        },
        py::arg("quats"), py::arg("order"),
        "Distance (radians) from gimbal lock per orientation (N, 4) if it were expressed in Euler `order`.");

    m.def(
        "closest_gimbal_approach",
        [](py::handle times, py::handle distances, double tolerance) {
            const GimbalApproach g = closest_gimbal_approach(to_doubles(times, "times"),
                                                             to_doubles(distances, "distances"), tolerance);
            return py::make_tuple(g.distance, to_array(g.times));
        },
        py::arg("times"), py::arg("distances"), py::arg("tolerance") = 1e-6,
        "(min_distance, times): the smallest gimbal distance and every sample time within `tolerance` "
        "radians of it.");

    m.def(
        "path_metrics",
        [](py::handle times, py::handle quats, py::handle key_times, py::handle reference,
           py::object key_quats) {
            const std::vector<Quat> keys =
                key_quats.is_none() ? std::vector<Quat>{} : to_quats(key_quats, "key_quats");
            const std::vector<double> t = to_doubles(times, "times"), kt = to_doubles(key_times, "key_times");
            const std::vector<Quat> q = to_quats(quats, "quats"), ref = to_quats(reference, "reference");
            PathMetrics r;
            {
                py::gil_scoped_release release;  // compare measures targets on worker threads
                r = path_metrics(t, q, kt, ref, keys);
            }
            py::dict d;
            d["deviation"] = to_array(r.deviation);
            d["max_deviation"] = r.max_deviation;
            d["max_deviation_time"] = r.max_deviation_time;
            d["mean_deviation"] = r.mean_deviation;
            d["speeds"] = to_array(r.speeds);
            d["segment_speed_ratios"] = to_array(r.segment_speed_ratios);
            d["speed_ratio"] = r.speed_ratio;
            d["path_length"] = r.path_length;
            d["key_path_length"] = r.key_path_length;
            d["path_length_ratio"] = r.path_length_ratio;
            d["velocity_jumps"] = to_array(r.key_jumps.velocity);
            d["acceleration_jumps"] = to_array(r.key_jumps.acceleration);
            d["max_velocity_jump"] = r.max_velocity_jump;
            d["max_velocity_jump_time"] = r.max_velocity_jump_time;
            d["max_acceleration_jump"] = r.max_acceleration_jump;
            d["max_acceleration_jump_time"] = r.max_acceleration_jump_time;
            return d;
        },
        py::arg("times"), py::arg("quats"), py::arg("key_times"), py::arg("reference"),
        py::arg("key_quats") = py::none(),
        "Every comparison metric of one sampled path, in radians and frames, as a dict: deviation (N,), "
        "max_deviation(_time), mean_deviation, speeds (N-1,), segment_speed_ratios (K-1,), speed_ratio, "
        "path_length, key_path_length (of key_quats, or of the path's samples at the key times), "
        "path_length_ratio, velocity_jumps / acceleration_jumps (K,), max_velocity_jump(_time), "
        "max_acceleration_jump(_time).");
}

}  // namespace quatcurve::bindings
