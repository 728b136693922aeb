// Bindings of channels.hpp: rotation channel values and the sampling policies. No formulas here.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "quatcurve/channels.hpp"

namespace quatcurve::bindings {

namespace {

std::vector<double> to_frames(py::handle obj, const char* name) {
    const Batch b = as_batch(obj, {}, name);
    if (b.batch_shape.size() != 1)
        throw py::value_error(std::string(name) + ": expected shape (N,), got " + shape_string(b.array));
    return std::vector<double>(b.data(), b.data() + b.count);
}

DArray frames_array(const std::vector<double>& v) {
    DArray out(static_cast<py::ssize_t>(v.size()));
    std::copy(v.begin(), v.end(), out.mutable_data());
    return out;
}

EulerBranch parse_branch(const std::string& name) {
    if (name == "continuous") return EulerBranch::continuous;
    if (name == "blender") return EulerBranch::blender;
    throw InvalidArgument("euler: unknown branch policy '" + name + "' (expected continuous or blender)");
}

}  // namespace

void bind_channels(py::module_& m) {
    m.def(
        "quats_to_channels",
        [](py::handle quats, const std::string& mode_name, py::object reference, const std::string& euler) {
            const RotationMode mode = parse_rotation_mode(mode_name);
            const EulerBranch branch = parse_branch(euler);
            const py::ssize_t c = static_cast<py::ssize_t>(channel_count(mode));
            const Batch q = as_batch(quats, {4}, "quats");
            if (q.batch_shape.size() != 1)
                throw py::value_error("quats: expected shape (N, 4), got " + shape_string(q.array));
            std::vector<Quat> qs(q.count);
            for (std::size_t s = 0; s < q.count; ++s) qs[s] = from_wxyz(q.data() + 4 * s);
            Batch ref;
            std::size_t rows = 0;
            if (!reference.is_none()) {
                ref = as_batch(reference, {c}, "reference");
                if (ref.batch_shape.size() > 1)
                    throw py::value_error("reference: expected shape (" + std::to_string(c) + ",) or (N, " +
                                          std::to_string(c) + "), got " + shape_string(ref.array));
                rows = ref.batch_shape.empty() ? 1 : ref.count;
            }
            std::vector<double> v;
            {
                py::gil_scoped_release release;  // the bake converts targets on several threads
                v = quats_to_channels(qs, mode, rows ? ref.data() : nullptr, rows, branch);
            }
            DArray out(std::vector<py::ssize_t>{static_cast<py::ssize_t>(q.count), c});
            std::copy(v.begin(), v.end(), out.mutable_data());
            return out;
        },
        py::arg("quats"), py::arg("mode"), py::arg("reference") = py::none(), py::arg("euler") = "continuous",
        "Channel values (N, 4|3) of rotation mode `mode` ('QUATERNION', 'XYZ'...'ZYX', 'AXIS_ANGLE') "
        "for the orientations quats (N, 4), continuous along them: hemisphere-continuous quaternions; "
        "axis-angle (angle, x, y, z) with the axis on its predecessor's side and the angle unwrapped; "
        "Euler angles (about X, Y, Z) without flips or 2 pi jumps. reference: one row of channel "
        "values the first sample is chosen nearest to, or (Euler) one row per sample. euler: "
        "'continuous' (euler_compat to the reference, then filtered from the sample farthest from "
        "gimbal lock: for baked curves) or 'blender' (Blender's Quaternion.to_euler(order, previous) "
        "along the samples, the first to_euler(order) or to_euler(order, reference)). Zero-length "
        "quats raise ValueError.");
    m.def(
        "axis_angle_span",
        [](py::handle quats, py::handle start, py::handle end) {
            const Batch q = as_batch(quats, {4}, "quats");
            if (q.batch_shape.size() != 1)
                throw py::value_error("quats: expected shape (N, 4), got " + shape_string(q.array));
            const Batch a = as_batch(start, {4}, "start"), b = as_batch(end, {4}, "end");
            if (!a.batch_shape.empty() || !b.batch_shape.empty())
                throw py::value_error("start, end: expected one row (4,) each");
            std::vector<Quat> qs(q.count);
            for (std::size_t s = 0; s < q.count; ++s) qs[s] = from_wxyz(q.data() + 4 * s);
            std::vector<double> v;
            {
                py::gil_scoped_release release;
                v = axis_angle_span_channels(qs, a.data(), b.data());
            }
            DArray out(std::vector<py::ssize_t>{static_cast<py::ssize_t>(q.count), 4});
            std::copy(v.begin(), v.end(), out.mutable_data());
            return out;
        },
        py::arg("quats"), py::arg("start"), py::arg("end"),
        "Axis-angle channels (N, 4) of the samples quats (N, 4) of a path from the key `start` to the "
        "key `end` (rows (angle, x, y, z)): quats_to_channels(quats, 'AXIS_ANGLE', start) when that "
        "arrives at `end` as keyed; otherwise the samples from the one nearest the identity on are "
        "lifted backwards from `end` (near the identity the axis is undefined, and a path passing it "
        "may come out on the other representation (a, v) = (4 pi k - a, -v)).");
    m.def(
        "channels_to_quats",
        [](py::handle values, const std::string& mode_name) {
            const RotationMode mode = parse_rotation_mode(mode_name);
            const py::ssize_t c = static_cast<py::ssize_t>(channel_count(mode));
            const Batch v = as_batch(values, {c}, "values");
            DArray out = make_output(v.batch_shape, {4});
            double* p = out.mutable_data();
            for (std::size_t s = 0; s < v.count; ++s)
                to_wxyz(channels_to_quat(v.data() + c * s, mode, s), p + 4 * s);
            return out;
        },
        py::arg("values"), py::arg("mode"),
        "Unit quaternions (..., 4) of channel values (..., 4|3) in rotation mode `mode`, as Blender "
        "builds the rotation: quaternions normalized, Euler angles (about X, Y, Z) in the order's "
        "product, axis-angle (angle, x, y, z) with the axis normalized. A zero-length quaternion or "
        "axis, or a non-finite value, raises ValueError naming the row.");
    m.def(
        "quat_to_euler_blender",
        [](py::handle qo, const std::string& order, py::object compat) {
            const EulerOrder o = parse_euler_order(order);
            const Batch q = as_batch(qo, {4}, "q");
            Batch ref;
            if (!compat.is_none()) {
                ref = as_batch(compat, {3}, "compat");
                if (ref.batch_shape != q.batch_shape && !ref.batch_shape.empty())
                    throw py::value_error("compat: expected shape (3,) or the shape of q with 3 last, got " +
                                          shape_string(ref.array));
            }
            DArray out = make_output(q.batch_shape, {3});
            double* p = out.mutable_data();
            for (std::size_t s = 0; s < q.count; ++s) {
                const Quat qs = from_wxyz(q.data() + 4 * s);
                check_nonzero(qs, element_name("q", q, s));
                Vec3 e;
                if (compat.is_none()) {
                    e = blender_quat_to_euler(qs, o);
                } else {
                    const double* r = ref.data() + (ref.batch_shape.empty() ? 0 : 3 * s);
                    e = blender_quat_to_euler(qs, o, Vec3(r[0], r[1], r[2]));
                }
                p[3 * s] = e.x, p[3 * s + 1] = e.y, p[3 * s + 2] = e.z;
            }
            return out;
        },
        py::arg("q"), py::arg("order") = "XYZ", py::arg("compat") = py::none(),
        "Blender's Quaternion.to_euler(order[, compat]), (..., 4) -> (..., 3): of the two Euler "
        "solutions, the smaller by the sum of absolute angles, or with compat ((3,) or one per q) "
        "each made compatible with it as Blender does and the nearer by the sum of absolute "
        "differences. Within 16 float32 epsilons of gimbal lock the last angle is 0, as Blender.");
    m.def("step_frames", [](double start, double end, double step) { return frames_array(step_frames(start, end, step)); },
          py::arg("start"), py::arg("end"), py::arg("step"),
          "The frames a bake keys: start, start + step, ... within end, and end itself (N,).");
    m.def("sample_frames",
          [](py::handle keys, int per_frame) { return frames_array(sample_frames(to_frames(keys, "key_frames"), per_frame)); },
          py::arg("key_frames"), py::arg("per_frame") = 1,
          "Samples over a keyed range: every 1/per_frame frame from the first key to the last (grid "
          "points within 1e-4 frames of a key, or on any sample's float32 frame, give way) and every key, "
          "sorted (N,), each on a float32 frame of its own.");
    m.def("whole_frame_samples",
          [](py::handle keys) { return frames_array(whole_frame_samples(to_frames(keys, "key_frames"))); },
          py::arg("key_frames"), "Every whole frame from the first key to the last and every key, sorted (N,).");
    m.def(
        "segment_handles",
        [](py::handle frames, py::handle values) {
            const std::vector<double> f = to_frames(frames, "frames"), v = to_frames(values, "values");
            if (f.size() != v.size())
                throw py::value_error("values: expected as many as frames (" + std::to_string(f.size()) + "), got " +
                                      std::to_string(v.size()));
            for (std::size_t s = 0; s < f.size(); ++s) {
                check_finite(f[s], "frames[" + std::to_string(s) + "]");
                check_finite(v[s], "values[" + std::to_string(s) + "]");
            }
            const py::ssize_t n = static_cast<py::ssize_t>(f.size());
            DArray left(std::vector<py::ssize_t>{n, 2}), right(std::vector<py::ssize_t>{n, 2});
            segment_handles(f.data(), v.data(), f.size(), left.mutable_data(), right.mutable_data());
            return py::make_tuple(left, right);
        },
        py::arg("frames"), py::arg("values"),
        "(left, right) handles (N, 2) of (frame, value) for keys on straight segments: a third of the "
        "way to each neighbour; end keys mirror their only segment; a lone key gets flat handles one "
        "frame wide.");
}

}  // namespace quatcurve::bindings
