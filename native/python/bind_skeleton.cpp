// Bindings of skeletons (skeleton.hpp): quatcurve.Skeleton and its results. Bindings only bind:
// arrays in, the native library, arrays out; every check and formula lives in
// native/src/skeleton*.cpp.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "quatcurve/blender_eval.hpp"
#include "quatcurve/channels.hpp"
#include "quatcurve/skeleton.hpp"

namespace quatcurve::bindings {

namespace {

// A (B, N, width) array as B·N rows, bone-major.
Batch read_bone_rows(py::handle obj, py::ssize_t width, const char* name, std::size_t bones, std::size_t& samples,
                     bool samples_known) {
    Batch b = as_batch(obj, {width}, name);
    if (b.batch_shape.size() != 2 || static_cast<std::size_t>(b.batch_shape[0]) != bones)
        throw py::value_error(std::string(name) + ": expected shape (" + std::to_string(bones) + ", N, " +
                              std::to_string(width) + "), got " + shape_string(b.array));
    const std::size_t n = static_cast<std::size_t>(b.batch_shape[1]);
    if (samples_known && n != samples)
        throw py::value_error(std::string(name) + ": " + std::to_string(n) + " samples, expected " +
                              std::to_string(samples));
    samples = n;
    return b;
}

std::vector<Vec3> vec3s(const Batch& b) {
    std::vector<Vec3> out(b.count);
    for (std::size_t k = 0; k < b.count; ++k) out[k] = Vec3(b.data()[3 * k], b.data()[3 * k + 1], b.data()[3 * k + 2]);
    return out;
}

SkeletonPose read_pose(const Skeleton& sk, py::handle locations, py::handle rotations, py::handle scales,
                       const char* prefix) {
    SkeletonPose p;
    const std::string l = std::string(prefix) + "locations", r = std::string(prefix) + "rotations",
                      s = std::string(prefix) + "scales";
    const Batch rb = read_bone_rows(rotations, 4, r.c_str(), sk.size(), p.samples, false);
    const Batch lb = read_bone_rows(locations, 3, l.c_str(), sk.size(), p.samples, true);
    const Batch sb = read_bone_rows(scales, 3, s.c_str(), sk.size(), p.samples, true);
    p.location = vec3s(lb);
    p.scale = vec3s(sb);
    p.rotation.resize(rb.count);
    for (std::size_t k = 0; k < rb.count; ++k) p.rotation[k] = from_wxyz(rb.data() + 4 * k);
    return p;
}

// The pose arrays of one motion: a (locations, rotations, scales) tuple.
SkeletonPose read_motion(const Skeleton& sk, py::handle motion, const char* name) {
    if (!py::isinstance<py::sequence>(motion) || py::isinstance<py::str>(motion) || py::len(motion) != 3)
        throw py::type_error(std::string(name) + ": expected (locations, rotations, scales)");
    const py::sequence m = py::reinterpret_borrow<py::sequence>(motion);
    return read_pose(sk, m[0], m[1], m[2], (std::string(name) + ".").c_str());
}

std::vector<unsigned char> read_flags(py::handle obj, std::size_t bones, unsigned char fallback, const char* name) {
    if (obj.is_none()) return std::vector<unsigned char>(bones, fallback);
    const Batch b = as_batch(obj, {}, name);
    if (b.batch_shape.size() != 1 || b.count != bones)
        throw py::value_error(std::string(name) + ": expected shape (" + std::to_string(bones) + ",), got " +
                              shape_string(b.array));
    std::vector<unsigned char> out(bones);
    for (std::size_t k = 0; k < bones; ++k) out[k] = b.data()[k] != 0.0;
    return out;
}

Skeleton make_skeleton(py::handle parents, py::handle rest, py::handle lengths, py::handle inherit_rotation,
                       py::handle connected, py::object inherit_scale) {
    Skeleton sk;
    const Batch pb = as_batch(parents, {}, "parents");
    if (pb.batch_shape.size() != 1) throw py::value_error("parents: expected shape (B,), got " + shape_string(pb.array));
    const std::size_t bones = pb.count;
    for (std::size_t k = 0; k < bones; ++k) {
        const double v = pb.data()[k];
        if (!(v >= -1.0) || v != static_cast<double>(static_cast<std::int64_t>(v)) || v >= static_cast<double>(bones))
            throw py::value_error("parents[" + std::to_string(k) + "]: not -1 or a bone index");
        sk.parents.push_back(static_cast<int>(v));
    }
    const Batch rb = as_batch(rest, {4, 4}, "rest");
    if (rb.batch_shape.size() != 1 || rb.count != bones)
        throw py::value_error("rest: expected shape (" + std::to_string(bones) + ", 4, 4), got " + shape_string(rb.array));
    for (std::size_t k = 0; k < bones; ++k) {
        Mat4 m;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) m[c][r] = rb.data()[16 * k + 4 * r + c];  // numpy rows → GLM columns
        sk.rest.push_back(m);
    }
    const Batch lb = as_batch(lengths, {}, "lengths");
    if (lb.batch_shape.size() != 1 || lb.count != bones)
        throw py::value_error("lengths: expected shape (" + std::to_string(bones) + ",), got " + shape_string(lb.array));
    sk.lengths.assign(lb.data(), lb.data() + bones);
    sk.inherit_rotation = read_flags(inherit_rotation, bones, 1, "inherit_rotation");
    sk.connected = read_flags(connected, bones, 0, "connected");
    sk.inherit_scale.assign(bones, InheritScale::FULL);
    if (!inherit_scale.is_none()) {
        const auto names = inherit_scale.cast<std::vector<std::string>>();
        if (names.size() != bones)
            throw py::value_error("inherit_scale: " + std::to_string(names.size()) + " modes for " +
                                  std::to_string(bones) + " bones");
        for (std::size_t k = 0; k < bones; ++k) {
            if (names[k] == "FULL") sk.inherit_scale[k] = InheritScale::FULL;
            else if (names[k] == "NONE") sk.inherit_scale[k] = InheritScale::NONE;
            else
                throw py::value_error("inherit_scale[" + std::to_string(k) + "]: " + names[k] +
                                      " (FULL and NONE are modelled)");
        }
    }
    check_skeleton(sk);
    return sk;
}

DArray mat4_array(const std::vector<Mat4>& m, std::size_t bones, std::size_t samples) {
    DArray out({static_cast<py::ssize_t>(bones), static_cast<py::ssize_t>(samples), py::ssize_t{4}, py::ssize_t{4}});
    double* p = out.mutable_data();
    for (std::size_t k = 0; k < m.size(); ++k)
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) p[16 * k + 4 * r + c] = m[k][c][r];
    return out;
}

std::vector<Mat4> read_pose_matrices(const Skeleton& sk, py::handle pose, std::size_t& samples) {
    const Batch b = as_batch(pose, {4, 4}, "pose");
    if (b.batch_shape.size() != 2 || static_cast<std::size_t>(b.batch_shape[0]) != sk.size())
        throw py::value_error("pose: expected shape (" + std::to_string(sk.size()) + ", N, 4, 4), got " +
                              shape_string(b.array));
    samples = static_cast<std::size_t>(b.batch_shape[1]);
    std::vector<Mat4> out(b.count);
    for (std::size_t k = 0; k < b.count; ++k) {
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) out[k][c][r] = b.data()[16 * k + 4 * r + c];
        const std::string problem = finite_problem(out[k]);
        if (!problem.empty()) throw py::value_error(element_name("pose", b, k) + ": " + problem);
    }
    return out;
}

// SkeletonReduction and SkeletonSlerpReduction: the same record over two kinds of keys.
template <class Result>
void bind_reduction(py::module_& m, const char* name, const char* doc, const char* keys_doc) {
    py::class_<Result>(m, name, doc)
        .def_readonly("keys", &Result::keys, keys_doc)
        .def_property_readonly("budgets", [](const Result& r) {
            DArray a(static_cast<py::ssize_t>(r.budgets.size()));
            std::copy(r.budgets.begin(), r.budgets.end(), a.mutable_data());
            return a;
        }, "(B,) the angular tolerance (radians) each bone was reduced at")
        .def_readonly("error", &Result::error, "the verified VertexError, reduced vs original")
        .def_readonly("rounds", &Result::rounds, "reductions of the skeleton made")
        .def_property_readonly("key_count", &Result::key_count, "keys over bones (and channels)")
        .def("__repr__", [name](const Result& r) {
            return "<" + std::string(name) + " " + std::to_string(r.keys.size()) + " bones, " +
                   std::to_string(r.key_count()) + " keys, error " + std::to_string(r.error.distance) + ">";
        });
}

}  // namespace

void bind_skeleton(py::module_& m) {
    py::class_<VertexError>(m, "VertexError", "The largest virtual-vertex distance of two motions, and where.")
        .def_readonly("distance", &VertexError::distance, "max over bones, samples and vertices (scene units)")
        .def_readonly("bone", &VertexError::bone, "the bone where it is (-1: no sample)")
        .def_readonly("vertex", &VertexError::vertex, "0 tail, 1..3 shell point along X, Y, Z")
        .def_readonly("sample", &VertexError::sample, "the sample where it is")
        .def_property_readonly("per_bone", [](const VertexError& e) {
            DArray a(static_cast<py::ssize_t>(e.per_bone.size()));
            std::copy(e.per_bone.begin(), e.per_bone.end(), a.mutable_data());
            return a;
        }, "(B,) the max of each bone")
        .def("__repr__", [](const VertexError& e) {
            return "<VertexError " + std::to_string(e.distance) + " at bone " + std::to_string(e.bone) + " vertex " +
                   std::to_string(e.vertex) + " sample " + std::to_string(e.sample) + ">";
        });

    bind_reduction<SkeletonReduction>(m, "SkeletonReduction",
                                      "Every bone's reduced rotation keys (ReducedKeys) under a distance bound, verified.",
                                      "per bone: its ReducedKeys");
    bind_reduction<SkeletonSlerpReduction>(
        m, "SkeletonSlerpReduction", "Every bone's glTF slerp keys (ProvedSlerpKeys) under a distance bound, verified.",
        "per bone: its ProvedSlerpKeys (no keys for a bone kept as it is)");

    py::class_<Skeleton>(m, "Skeleton", R"doc(An armature's bones as plain arrays, posed as Blender poses them.

parents: (B,) parent index per bone, -1 for a root, parents before children; rest: (B, 4, 4)
bone.matrix_local (armature space, rigid); lengths: (B,) bone.length; inherit_rotation, connected:
(B,) booleans (default True, False); inherit_scale: B names, 'FULL' (default) or 'NONE'.
Quaternions (w, x, y, z); lengths in scene units; docs/reduce.md, "Distance bound".)doc")
        .def(py::init([](py::handle parents, py::handle rest, py::handle lengths, py::handle inherit_rotation,
                         py::handle connected, py::object inherit_scale) {
                 return make_skeleton(parents, rest, lengths, inherit_rotation, connected, std::move(inherit_scale));
             }),
             py::arg("parents"), py::arg("rest"), py::arg("lengths"), py::arg("inherit_rotation") = py::none(),
             py::arg("connected") = py::none(), py::arg("inherit_scale") = py::none())
        .def_property_readonly("bone_count", &Skeleton::size)
        .def(
            "pose",
            [](const Skeleton& sk, py::handle locations, py::handle rotations, py::handle scales) {
                const SkeletonPose p = read_pose(sk, locations, rotations, scales, "");
                std::vector<Mat4> out;
                {
                    py::gil_scoped_release release;
                    out = pose_matrices(sk, p);
                }
                return mat4_array(out, sk.size(), p.samples);
            },
            py::arg("locations"), py::arg("rotations"), py::arg("scales"),
            "Blender's pose_bone.matrix (armature space) per bone and sample, (B, N, 4, 4), from the local "
            "channels locations (B, N, 3), rotations (B, N, 4) (w, x, y, z; normalized as Blender does), "
            "scales (B, N, 3).")
        .def(
            "virtual_vertices",
            [](const Skeleton& sk, py::handle pose, double shell) {
                std::size_t n = 0;
                const std::vector<Mat4> mats = read_pose_matrices(sk, pose, n);
                const std::vector<Vec3> v = virtual_vertices(sk, mats, n, shell);
                DArray out({static_cast<py::ssize_t>(sk.size()), static_cast<py::ssize_t>(n),
                            py::ssize_t{kVirtualVertices}, py::ssize_t{3}});
                for (std::size_t k = 0; k < v.size(); ++k)
                    for (int c = 0; c < 3; ++c) out.mutable_data()[3 * k + c] = v[k][c];
                return out;
            },
            py::arg("pose"), py::arg("shell"),
            "(B, N, 4, 3): per bone and sample the tail and the points at `shell` along the posed bone's "
            "X, Y, Z axes, from pose matrices (B, N, 4, 4) as pose() returns them.")
        .def(
            "vertex_error",
            [](const Skeleton& sk, py::handle a, py::handle b, double shell) {
                const SkeletonPose pa = read_motion(sk, a, "a"), pb = read_motion(sk, b, "b");
                py::gil_scoped_release release;
                return virtual_vertex_error(sk, pa, pb, shell);
            },
            py::arg("a"), py::arg("b"), py::arg("shell"),
            "VertexError of two motions, each (locations, rotations, scales) as pose() takes them.")
        .def(
            "vertex_distances",
            [](const Skeleton& sk, py::handle a, py::handle b, double shell) {
                const SkeletonPose pa = read_motion(sk, a, "a"), pb = read_motion(sk, b, "b");
                std::vector<double> d;
                {
                    py::gil_scoped_release release;
                    d = virtual_vertex_distances(sk, pa, pb, shell);
                }
                DArray out({static_cast<py::ssize_t>(sk.size()), static_cast<py::ssize_t>(pa.samples)});
                std::copy(d.begin(), d.end(), out.mutable_data());
                return out;
            },
            py::arg("a"), py::arg("b"), py::arg("shell"),
            "(B, N): per bone and sample the largest distance between the same virtual vertex of motions a and "
            "b (each (locations, rotations, scales) as pose() takes them); vertex_error is its maximum.")
        .def(
            "dominant_shell_budgets",
            [](const Skeleton& sk, py::handle pose, double distance, double shell) {
                std::size_t n = 0;
                const std::vector<Mat4> mats = read_pose_matrices(sk, pose, n);
                const std::vector<double> b = dominant_shell_budgets(sk, mats, n, distance, shell);
                DArray out(static_cast<py::ssize_t>(b.size()));
                std::copy(b.begin(), b.end(), out.mutable_data());
                return out;
            },
            py::arg("pose"), py::arg("distance"), py::arg("shell"),
            "(B,) ACL's per-bone angular budgets (radians): distance / the largest distance from the bone's "
            "head to a virtual vertex of it or its descendants over the pose's samples.")
        .def(
            "reduce",
            [](const Skeleton& sk, py::handle times, py::sequence rotations, py::handle locations, py::handle scales,
               double distance, double shell, const std::string& interpolation, bool synchronized,
               py::object reduced) {
                const KeyInterpolation ipo = parse_key_interpolation(interpolation);
                const Batch tb = as_batch(times, {}, "times");
                if (tb.batch_shape.size() != 1)
                    throw py::value_error("times: expected a 1-D array, got shape " + shape_string(tb.array));
                const std::vector<double> t(tb.data(), tb.data() + tb.count);
                if (static_cast<std::size_t>(py::len(rotations)) != sk.size())
                    throw py::value_error("rotations: " + std::to_string(py::len(rotations)) + " bones for " +
                                          std::to_string(sk.size()));
                std::vector<BoneChannels> rot(sk.size());
                for (std::size_t b = 0; b < sk.size(); ++b) {
                    const std::string name = "rotations[" + std::to_string(b) + "]";
                    py::handle item = rotations[b];
                    if (!py::isinstance<py::sequence>(item) || py::isinstance<py::str>(item) || py::len(item) != 2)
                        throw py::type_error(name + ": expected (mode, values)");
                    const py::sequence pair = py::reinterpret_borrow<py::sequence>(item);
                    rot[b].mode = parse_rotation_mode(pair[0].cast<std::string>());
                    const py::ssize_t c = static_cast<py::ssize_t>(channel_count(rot[b].mode));
                    const Batch v = as_batch(pair[1], {c}, name.c_str());
                    if (v.batch_shape.size() != 1 || v.count != t.size())
                        throw py::value_error(name + ": expected shape (" + std::to_string(t.size()) + ", " +
                                              std::to_string(c) + "), got " + shape_string(v.array));
                    rot[b].values.assign(v.data(), v.data() + v.count * static_cast<std::size_t>(c));
                }
                if (!reduced.is_none()) {
                    const py::sequence flags = reduced.cast<py::sequence>();
                    if (static_cast<std::size_t>(py::len(flags)) != sk.size())
                        throw py::value_error("reduced: " + std::to_string(py::len(flags)) + " flags for " +
                                              std::to_string(sk.size()) + " bones");
                    for (std::size_t b = 0; b < sk.size(); ++b) rot[b].reduce = py::bool_(flags[b]);
                }
                std::size_t n = t.size();
                const std::vector<Vec3> loc = vec3s(read_bone_rows(locations, 3, "locations", sk.size(), n, true));
                const std::vector<Vec3> scl = vec3s(read_bone_rows(scales, 3, "scales", sk.size(), n, true));
                py::gil_scoped_release release;
                return reduce_skeleton(sk, t, rot, loc, scl, distance, shell, ipo, synchronized);
            },
            py::arg("times"), py::arg("rotations"), py::arg("locations"), py::arg("scales"), py::arg("distance"),
            py::arg("shell"), py::arg("interpolation") = "BEZIER", py::arg("synchronized") = false,
            py::arg("reduced") = py::none(),
            R"doc(Reduce every bone's rotation keys so that no virtual vertex (tail, and the points at `shell`
along the posed bone's axes) moves more than `distance` from the original pose at any sample.

times: (N,) the frames every bone was sampled at (every whole frame and every original key);
rotations: per bone (mode, values): mode 'QUATERNION', an Euler order or 'AXIS_ANGLE', values (N, 4)
or (N, 3) Blender's evaluation of its rotation channels; locations, scales: (B, N, 3), read, kept;
reduced: (B,) booleans, the bones whose keys are reduced (default all): the others keep their
sampled rotation and get empty ReducedKeys.
Returns a SkeletonReduction: per-bone ReducedKeys (as reduce_keys* returns them), the budgets, and the
error verified by posing Blender's float32 evaluation of the keys.)doc")
        .def(
            "reduce_slerp",
            [](const Skeleton& sk, py::handle times, py::handle rotations, py::handle locations, py::handle scales,
               double distance, double shell, py::sequence bones) {
                const Batch tb = as_batch(times, {}, "times");
                if (tb.batch_shape.size() != 1)
                    throw py::value_error("times: expected a 1-D array, got shape " + shape_string(tb.array));
                const std::vector<double> t(tb.data(), tb.data() + tb.count);
                std::size_t n = t.size();
                const Batch rb = read_bone_rows(rotations, 4, "rotations", sk.size(), n, true);
                std::vector<Quat> rot(rb.count);
                for (std::size_t k = 0; k < rb.count; ++k) rot[k] = from_wxyz(rb.data() + 4 * k);
                const std::vector<Vec3> loc = vec3s(read_bone_rows(locations, 3, "locations", sk.size(), n, true));
                const std::vector<Vec3> scl = vec3s(read_bone_rows(scales, 3, "scales", sk.size(), n, true));
                if (static_cast<std::size_t>(py::len(bones)) != sk.size())
                    throw py::value_error("bones: " + std::to_string(py::len(bones)) + " for " + std::to_string(sk.size()));
                std::vector<SlerpBone> spec(sk.size());
                for (std::size_t b = 0; b < sk.size(); ++b) {
                    if (bones[b].is_none()) spec[b].reduce = false;
                    else if (py::isinstance<SlerpBone>(bones[b])) spec[b] = bones[b].cast<SlerpBone>();
                    else throw py::type_error("bones[" + std::to_string(b) + "]: expected a SlerpBone or None");
                }
                py::gil_scoped_release release;
                return reduce_skeleton_slerp(sk, t, rot, loc, scl, distance, shell, spec);
            },
            py::arg("times"), py::arg("rotations"), py::arg("locations"), py::arg("scales"), py::arg("distance"),
            py::arg("shell"), py::arg("bones"),
            R"doc(glTF LINEAR (slerp) keys for every bone so that no virtual vertex moves more than `distance` from
the original pose at any sample, each bone's keys proved within its budget of its reference at
every instant (or held at its samples).

times: (N,) the samples the distance is verified at (every frame and every original key);
rotations: (B, N, 4) the original rotation of every bone there (its reference sampled); locations,
scales: (B, N, 3), read, kept; bones: per bone a SlerpBone (its candidate times and reference) or
None (kept as it is, no keys). Returns a SkeletonSlerpReduction: per bone its ProvedSlerpKeys
(times in frames), the budgets, and the error verified by posing the keys as a glTF reader plays
them (play_slerp_keys: float32 quaternions, slerp).)doc");
}

}  // namespace quatcurve::bindings
