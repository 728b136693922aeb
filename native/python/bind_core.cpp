// Bindings of the orientation core (quat.hpp, euler.hpp): numpy batches in, numpy batches out.
// Each function converts its arrays, checks every element with the native *_problem functions (so
// the ValueError names the element: "q[3]: zero-length quaternion"), and loops over the native
// function. No formulas here.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/quat.hpp"

namespace quatcurve::bindings {

namespace {

// ---- reading and writing elements ------------------------------------------------------------------

enum class Need { finite, nonzero };  // what a quaternion or vector argument must be

void require(const std::string& problem, const char* name, const std::vector<py::ssize_t>& shape,
             std::size_t i) {
    if (!problem.empty()) throw InvalidArgument(element_name(name, shape, i) + ": " + problem);
}

Quat read_quat(const Batch& b, std::size_t i, const char* name, Need need) {
    const Quat q = from_wxyz(b.data() + 4 * i);
    require(need == Need::nonzero ? nonzero_problem(q) : finite_problem(q), name, b.batch_shape, i);
    return q;
}

Vec3 read_vec(const Batch& b, std::size_t i, const char* name, Need need = Need::finite,
              const char* noun = "vector") {
    const double* p = b.data() + 3 * i;
    const Vec3 v(p[0], p[1], p[2]);
    require(need == Need::nonzero ? nonzero_problem(v, noun) : finite_problem(v), name, b.batch_shape, i);
    return v;
}

double read_scalar(const Batch& b, std::size_t i, const char* name) {
    const double x = b.data()[i];
    require(finite_problem(x), name, b.batch_shape, i);
    return x;
}

// numpy matrices are row-major, GLM's column-major: m[col][row] = p[row·n + col].
Mat4 read_mat4(const Batch& b, std::size_t i, const char* name) {
    const double* p = b.data() + 16 * i;
    Mat4 m;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) m[c][r] = p[4 * r + c];
    require(finite_problem(m), name, b.batch_shape, i);
    return m;
}

void write_quat(double* out, std::size_t i, const Quat& q) { to_wxyz(q, out + 4 * i); }

// A finite input can still have a result beyond double range (the product of two 1e200
// quaternions, e^w for w > 709, a 1e308 vector rotated): refuse it, naming the element, rather than
// return inf or nan. `out` holds the batch's elements of `tail` doubles each.
void require_finite_result(const DArray& out, const std::vector<py::ssize_t>& batch_shape, std::size_t tail) {
    const double* p = out.data();
    const std::size_t n = static_cast<std::size_t>(out.size());
    for (std::size_t k = 0; k < n; ++k)
        if (!std::isfinite(p[k]))
            throw InvalidArgument(element_name("result", batch_shape, k / tail) +
                                  ": overflows double precision (the input is too large)");
}

void write_vec(double* out, std::size_t i, const Vec3& v) {
    double* p = out + 3 * i;
    p[0] = v.x, p[1] = v.y, p[2] = v.z;
}

void write_mat3(double* out, std::size_t i, const Mat3& m) {
    double* p = out + 9 * i;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) p[3 * r + c] = m[c][r];
}

void write_mat4(double* out, std::size_t i, const Mat4& m) {
    double* p = out + 16 * i;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) p[4 * r + c] = m[c][r];
}

// A batch of (..., 3, 3) rotation matrices, or of (..., 4, 4) transforms whose upper-left 3×3 is
// the rotation. at() checks the element (finite; not singular; no reflection).
struct RotationMatrices {
    Batch batch;
    int n = 3;
    const char* name;

    RotationMatrices(py::handle obj, const char* arg, bool allow4) : name(arg) {
        py::array probe = py::array::ensure(obj);
        const bool is4 = allow4 && probe && probe.ndim() >= 2 && probe.shape(probe.ndim() - 1) == 4 &&
                         probe.shape(probe.ndim() - 2) == 4;
        if (allow4 && !is4 && !(probe && probe.ndim() >= 2 && probe.shape(probe.ndim() - 1) == 3 &&
                                probe.shape(probe.ndim() - 2) == 3))
            throw py::value_error(std::string(arg) + ": expected shape (..., 3, 3) or (..., 4, 4), got " +
                                  (probe ? shape_string(probe) : std::string("a non-array")));
        n = is4 ? 4 : 3;
        batch = as_batch(obj, {n, n}, arg);
    }

    Mat3 at(std::size_t i) const {
        Mat3 m;
        if (n == 4) {
            m = Mat3(read_mat4(batch, i, name));
        } else {
            const double* p = batch.data() + 9 * i;
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) m[c][r] = p[3 * r + c];
        }
        require(rotation_matrix_problem(m), name, batch.batch_shape, i);
        return m;
    }
};

// ---- loop shapes ---------------------------------------------------------------------------------

// (..., 4) -> (..., 4)
template <class Fn>
DArray map_quat(py::handle qo, Need need, Fn fn) {
    const Batch q = as_batch(qo, {4}, "q");
    DArray out = make_output(q.batch_shape, {4});
    double* o = out.mutable_data();
    for (std::size_t i = 0; i < q.count; ++i) write_quat(o, i, fn(read_quat(q, i, "q", need)));
    require_finite_result(out, q.batch_shape, 4);
    return out;
}

// (..., 4), (..., 4) -> (..., 4), broadcasting
template <class Fn>
DArray map_quat_pair(py::handle ao, py::handle bo, Need need_a, Need need_b, Fn fn) {
    const Batch a = as_batch(ao, {4}, "a"), b = as_batch(bo, {4}, "b");
    const Broadcast bc = broadcast({{"a", &a.batch_shape}, {"b", &b.batch_shape}});
    DArray out = make_output(bc.shape, {4});
    double* o = out.mutable_data();
    for (std::size_t i = 0; i < bc.count; ++i)
        write_quat(o, i, fn(read_quat(a, bc.index(0, i), "a", need_a), read_quat(b, bc.index(1, i), "b", need_b)));
    require_finite_result(out, bc.shape, 4);
    return out;
}

// (..., 4), (..., 3) -> (..., 3), broadcasting
template <class Fn>
DArray map_quat_vec(py::handle qo, py::handle vo, const char* vname, Fn fn) {
    const Batch q = as_batch(qo, {4}, "q"), v = as_batch(vo, {3}, vname);
    const Broadcast bc = broadcast({{"q", &q.batch_shape}, {vname, &v.batch_shape}});
    DArray out = make_output(bc.shape, {3});
    double* o = out.mutable_data();
    for (std::size_t i = 0; i < bc.count; ++i)
        write_vec(o, i, fn(read_quat(q, bc.index(0, i), "q", Need::nonzero), read_vec(v, bc.index(1, i), vname)));
    require_finite_result(out, bc.shape, 3);
    return out;
}

// (..., 4, 4), (..., 3) -> (..., 3), broadcasting
template <class Fn>
DArray map_mat4_vec(py::handle mo, py::handle vo, const char* vname, Fn fn) {
    const Batch m = as_batch(mo, {4, 4}, "M"), v = as_batch(vo, {3}, vname);
    const Broadcast bc = broadcast({{"M", &m.batch_shape}, {vname, &v.batch_shape}});
    DArray out = make_output(bc.shape, {3});
    double* o = out.mutable_data();
    for (std::size_t i = 0; i < bc.count; ++i) {
        const Mat4 mi = read_mat4(m, bc.index(0, i), "M");
        const Vec3 vi = read_vec(v, bc.index(1, i), vname);
        try {
            write_vec(o, i, fn(mi, vi));
        } catch (const InvalidArgument& e) {  // the native message says what, the prefix which
            throw InvalidArgument(element_name(vname, bc.shape, i) + ": " + e.what());
        }
    }
    require_finite_result(out, bc.shape, 3);
    return out;
}

// (..., 3) -> (..., 4, 4)
template <class Fn>
DArray vec_to_mat4(py::handle vo, const char* vname, Fn fn) {
    const Batch v = as_batch(vo, {3}, vname);
    DArray out = make_output(v.batch_shape, {4, 4});
    double* o = out.mutable_data();
    for (std::size_t i = 0; i < v.count; ++i) write_mat4(o, i, fn(read_vec(v, i, vname)));
    return out;
}

// (..., 3) -> (..., 3, 3) / (..., 4) for Euler angles
template <class Fn>
DArray map_angles(py::handle ao, std::initializer_list<py::ssize_t> tail, Fn fn) {
    const Batch a = as_batch(ao, {3}, "angles");
    DArray out = make_output(a.batch_shape, tail);
    double* o = out.mutable_data();
    for (std::size_t i = 0; i < a.count; ++i) fn(o, i, read_vec(a, i, "angles"));
    return out;
}

// ---- docstrings ------------------------------------------------------------------------------------

#define QC_CONVENTIONS                                                                                \
    "\n\nConventions: quaternions are (w, x, y, z); angles in radians; matrices act on column "      \
    "vectors (P' = M @ P). Leading dimensions are batch dimensions. Non-finite input raises "        \
    "ValueError naming the element (e.g. 'q[3]: non-finite value nan in component x'), and so "    \
    "does a result that overflows double precision ('result[3]: overflows ...'): outputs are "      \
    "always finite."
#define QC_BROADCAST \
    " The batch dimensions of the inputs broadcast as in numpy (a single value against a batch)."
#define QC_EULER                                                                                      \
    "\n\nEuler angles follow Blender: order 'XYZ' means R = Rz @ Ry @ Rx (X first, about fixed "    \
    "axes; scipy's extrinsic 'xyz'); angles are always (about X, about Y, about Z) whatever the "    \
    "order. order is one of 'XYZ', 'XZY', 'YXZ', 'YZX', 'ZXY', 'ZYX' (else ValueError)."

}  // namespace

void bind_core(py::module_& m) {
    // ---- algebra ----
    m.def("quat_multiply",
          [](py::handle a, py::handle b) {
              return map_quat_pair(a, b, Need::finite, Need::finite, [](const Quat& x, const Quat& y) { return multiply(x, y); });
          },
          py::arg("a"), py::arg("b"),
          "Hamilton product a*b, (..., 4) x (..., 4) -> (..., 4). Any quaternions (no normalization); "
          "as rotations, b is applied first." QC_BROADCAST QC_CONVENTIONS);
    m.def("quat_conjugate", [](py::handle q) { return map_quat(q, Need::finite, [](const Quat& x) { return conjugate(x); }); },
          py::arg("q"), "(w, -x, -y, -z), (..., 4) -> (..., 4); the inverse rotation for unit q." QC_CONVENTIONS);
    m.def("quat_inverse", [](py::handle q) { return map_quat(q, Need::nonzero, [](const Quat& x) { return inverse(x); }); },
          py::arg("q"),
          "conj(q)/|q|^2, (..., 4) -> (..., 4). A zero-length q (|q| < 1e-300) raises ValueError." QC_CONVENTIONS);
    m.def("quat_divide",
          [](py::handle a, py::handle b) {
              return map_quat_pair(a, b, Need::finite, Need::nonzero, [](const Quat& x, const Quat& y) { return divide(x, y); });
          },
          py::arg("a"), py::arg("b"),
          "Right division a * b^-1, (..., 4) x (..., 4) -> (..., 4); a zero-length b raises ValueError."
          QC_BROADCAST QC_CONVENTIONS);
    m.def("quat_norm",
          [](py::handle qo) {
              const Batch q = as_batch(qo, {4}, "q");
              DArray out = make_output(q.batch_shape, {});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < q.count; ++i) o[i] = norm(read_quat(q, i, "q", Need::finite));
              require_finite_result(out, q.batch_shape, 1);
              return out;
          },
          py::arg("q"), "|q|, (..., 4) -> (...); overflow-safe (exact for components near 1e+-300; a norm beyond "
          "1.8e308 raises ValueError)." QC_CONVENTIONS);
    m.def("quat_normalize",
          [](py::handle q) { return map_quat(q, Need::nonzero, [](const Quat& x) { return normalized_rotation(x); }); },
          py::arg("q"),
          "q/|q|, (..., 4) -> (..., 4); the sign is kept. A zero-length q (|q| < 1e-300) raises ValueError."
          QC_CONVENTIONS);
    m.def("quat_exp", [](py::handle q) { return map_quat(q, Need::finite, [](const Quat& x) { return exp(x); }); },
          py::arg("q"),
          "Quaternion exponential e^q = e^w (cos|v|, sin|v| v/|v|), (..., 4) -> (..., 4), for any q "
          "(Taylor series for |v| -> 0). A result beyond double range (w > ~709) raises ValueError." QC_CONVENTIONS);
    m.def("quat_log", [](py::handle q) { return map_quat(q, Need::nonzero, [](const Quat& x) { return log(x); }); },
          py::arg("q"),
          "Quaternion logarithm (ln|q|, atan2(|v|, w) v/|v|), (..., 4) -> (..., 4); the vector part's "
          "length is in [0, pi]. Real q: (ln|w|, 0, 0, 0) for w > 0, (ln|w|, pi, 0, 0) for w < 0. "
          "Zero-length q raises ValueError." QC_CONVENTIONS);
    m.def("quat_pow",
          [](py::handle qo, py::handle to) {
              const Batch q = as_batch(qo, {4}, "q"), t = as_batch(to, {}, "t");
              const Broadcast bc = broadcast({{"q", &q.batch_shape}, {"t", &t.batch_shape}});
              DArray out = make_output(bc.shape, {4});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < bc.count; ++i)
                  write_quat(o, i, pow(read_quat(q, bc.index(0, i), "q", Need::nonzero), read_scalar(t, bc.index(1, i), "t")));
              require_finite_result(out, bc.shape, 4);
              return out;
          },
          py::arg("q"), py::arg("t"),
          "q^t = exp(t log q), q (..., 4), t (...) -> (..., 4). For unit q: t times q's rotation about "
          "its axis, the way q's hemisphere turns (w < 0 goes the long way). Zero-length q raises "
          "ValueError." QC_BROADCAST QC_CONVENTIONS);

    // ---- rotation of points ----
    m.def("quat_rotate",
          [](py::handle q, py::handle v) { return map_quat_vec(q, v, "v", [](const Quat& x, const Vec3& p) { return rotate(x, p); }); },
          py::arg("q"), py::arg("v"),
          "Rotate vectors by quaternions, q (..., 4), v (..., 3) -> (..., 3), with the fast form of "
          "q [0,v] q^-1. q is normalized first (a rotation is meant); zero-length q raises ValueError."
          QC_BROADCAST QC_CONVENTIONS);
    m.def("quat_rotate_sandwich",
          [](py::handle q, py::handle v) {
              return map_quat_vec(q, v, "v", [](const Quat& x, const Vec3& p) { return rotate_sandwich(x, p); });
          },
          py::arg("q"), py::arg("v"),
          "Literally q [0,v] q^-1 with two Hamilton products, q (..., 4), v (..., 3) -> (..., 3). Any "
          "nonzero q (its scale cancels); zero-length q raises ValueError." QC_BROADCAST QC_CONVENTIONS);

    // ---- axis-angle ----
    m.def("axis_angle_to_quat",
          [](py::handle axo, py::handle ango) {
              const Batch ax = as_batch(axo, {3}, "axis"), an = as_batch(ango, {}, "angle");
              const Broadcast bc = broadcast({{"axis", &ax.batch_shape}, {"angle", &an.batch_shape}});
              DArray out = make_output(bc.shape, {4});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < bc.count; ++i)
                  write_quat(o, i, axis_angle_to_quat(read_vec(ax, bc.index(0, i), "axis", Need::nonzero, "axis"),
                                                      read_scalar(an, bc.index(1, i), "angle")));
              return out;
          },
          py::arg("axis"), py::arg("angle"),
          "(cos(angle/2), sin(angle/2) axis/|axis|), axis (..., 3), angle (...) -> (..., 4). The axis is "
          "normalized; a zero-length axis raises ValueError; angles are not wrapped (2 pi gives "
          "(-1, 0, 0, 0))." QC_BROADCAST QC_CONVENTIONS);
    m.def("quat_to_axis_angle",
          [](py::handle qo) {
              const Batch q = as_batch(qo, {4}, "q");
              DArray axis = make_output(q.batch_shape, {3}), angle = make_output(q.batch_shape, {});
              double* ax = axis.mutable_data();
              double* an = angle.mutable_data();
              for (std::size_t i = 0; i < q.count; ++i) {
                  Vec3 a;
                  quat_to_axis_angle(read_quat(q, i, "q", Need::nonzero), a, an[i]);
                  write_vec(ax, i, a);
              }
              return py::make_tuple(axis, angle);
          },
          py::arg("q"),
          "(axis (..., 3), angle (...)) of q/|q| with angle = 2 atan2(|v|, w) in [0, 2 pi] (as Blender: "
          "w < 0 gives angles above pi) and a unit axis; the identity gives axis (0, 1, 0), angle 0 "
          "(Blender's default). Zero-length q raises ValueError." QC_CONVENTIONS);
    m.def("angle_between",
          [](py::handle ao, py::handle bo) {
              const Batch a = as_batch(ao, {4}, "a"), b = as_batch(bo, {4}, "b");
              const Broadcast bc = broadcast({{"a", &a.batch_shape}, {"b", &b.batch_shape}});
              DArray out = make_output(bc.shape, {});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < bc.count; ++i)
                  o[i] = angle_between(read_quat(a, bc.index(0, i), "a", Need::nonzero),
                                       read_quat(b, bc.index(1, i), "b", Need::nonzero));
              return out;
          },
          py::arg("a"), py::arg("b"),
          "Geodesic angle in [0, pi] between the rotations a and b, (..., 4) x (..., 4) -> (...). "
          "Sign-invariant (q and -q are the same rotation); computed as 4 atan2(|a - b|, |a + b|) on "
          "normalized inputs in the same hemisphere, accurate to ~1e-16 rad near 0 and near pi. "
          "Zero-length inputs raise ValueError." QC_BROADCAST QC_CONVENTIONS);

    // ---- matrices ----
    m.def("quat_to_matrix",
          [](py::handle qo) {
              const Batch q = as_batch(qo, {4}, "q");
              DArray out = make_output(q.batch_shape, {3, 3});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < q.count; ++i) write_mat3(o, i, quat_to_matrix(read_quat(q, i, "q", Need::nonzero)));
              return out;
          },
          py::arg("q"),
          "Rotation matrix of q/|q|, (..., 4) -> (..., 3, 3). Zero-length q raises ValueError." QC_CONVENTIONS);
    m.def("matrix_to_quat",
          [](py::handle mo) {
              const RotationMatrices ms(mo, "m", true);
              DArray out = make_output(ms.batch.batch_shape, {4});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < ms.batch.count; ++i) write_quat(o, i, matrix_to_quat(ms.at(i)));
              return out;
          },
          py::arg("m"),
          "Unit quaternion of a rotation matrix, (..., 3, 3) or (..., 4, 4) (upper-left 3x3 used) -> "
          "(..., 4), with w >= 0. Robust to scale (uniform or not), shear and slightly non-orthonormal "
          "input: the rotation nearest to m (polar decomposition) is converted. Singular matrices and "
          "reflections (det < 0) raise ValueError." QC_CONVENTIONS);
    m.def("nearest_rotation",
          [](py::handle mo) {
              const RotationMatrices ms(mo, "m", false);
              DArray out = make_output(ms.batch.batch_shape, {3, 3});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < ms.batch.count; ++i) write_mat3(o, i, nearest_rotation(ms.at(i)));
              return out;
          },
          py::arg("m"),
          "The rotation nearest to m in the Frobenius norm (orthogonal polar factor), (..., 3, 3) -> "
          "(..., 3, 3): removes scale and shear. Singular matrices and reflections raise ValueError."
          QC_CONVENTIONS);

    // ---- homogeneous transforms ----
    m.def("translation_matrix",
          [](py::handle t) { return vec_to_mat4(t, "t", [](const Vec3& v) { return translation_matrix(v); }); },
          py::arg("t"), "4x4 homogeneous translation by t, (..., 3) -> (..., 4, 4)." QC_CONVENTIONS);
    m.def("scale_matrix", [](py::handle s) { return vec_to_mat4(s, "s", [](const Vec3& v) { return scale_matrix(v); }); },
          py::arg("s"),
          "4x4 homogeneous scale diag(sx, sy, sz, 1), (..., 3) -> (..., 4, 4); negative entries reflect, "
          "zero entries project." QC_CONVENTIONS);
    m.def("rotation_matrix4",
          [](py::handle qo) {
              const Batch q = as_batch(qo, {4}, "q");
              DArray out = make_output(q.batch_shape, {4, 4});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < q.count; ++i) write_mat4(o, i, rotation_matrix4(read_quat(q, i, "q", Need::nonzero)));
              return out;
          },
          py::arg("q"),
          "4x4 homogeneous rotation of q/|q|, (..., 4) -> (..., 4, 4). Zero-length q raises ValueError."
          QC_CONVENTIONS);
    m.def("transform_points",
          [](py::handle mo, py::handle po) {
              return map_mat4_vec(mo, po, "P", [](const Mat4& x, const Vec3& p) { return transform_point(x, p); });
          },
          py::arg("M"), py::arg("P"),
          "Apply 4x4 transforms to points: (M @ [P, 1]).xyz / w, M (..., 4, 4), P (..., 3) -> (..., 3). "
          "Compose first (M1 @ M2 @ M3 applies M3 first). A point mapped to w = 0 raises ValueError."
          QC_BROADCAST QC_CONVENTIONS);
    m.def("transform_directions",
          [](py::handle mo, py::handle d) {
              return map_mat4_vec(mo, d, "D", [](const Mat4& x, const Vec3& v) { return transform_direction(x, v); });
          },
          py::arg("M"), py::arg("D"),
          "Apply 4x4 transforms to directions: (M @ [D, 0]).xyz, ignoring translation, M (..., 4, 4), "
          "D (..., 3) -> (..., 3)." QC_BROADCAST QC_CONVENTIONS);

    // ---- the two matrix representations ----
    m.def("quat_to_complex2",
          [](py::handle qo) {
              const Batch q = as_batch(qo, {4}, "q");
              CArray out = make_output<std::complex<double>>(q.batch_shape, {2, 2});
              std::complex<double>* o = out.mutable_data();
              for (std::size_t i = 0; i < q.count; ++i) {
                  const auto c = quat_to_complex2(read_quat(q, i, "q", Need::finite));
                  for (std::size_t n = 0; n < 4; ++n) o[4 * i + n] = c[n];
              }
              return out;
          },
          py::arg("q"),
          "The 2x2 complex matrix of q, [[w+ix, y+iz], [-y+iz, w-ix]], (..., 4) -> complex (..., 2, 2). "
          "Products map to products: C(a*b) = C(a) @ C(b); |q|^2 = det C(q)." QC_CONVENTIONS);
    m.def("complex2_to_quat",
          [](py::handle mo) {
              const ComplexBatch mb = as_complex_batch(mo, {2, 2}, "m");
              DArray out = make_output(mb.batch_shape, {4});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < mb.count; ++i) {
                  std::array<std::complex<double>, 4> c;
                  for (std::size_t n = 0; n < 4; ++n) c[n] = mb.data()[4 * i + n];
                  require(finite_problem(c), "m", mb.batch_shape, i);
                  write_quat(o, i, complex2_to_quat(c));
              }
              require_finite_result(out, mb.batch_shape, 4);
              return out;
          },
          py::arg("m"),
          "Inverse of quat_to_complex2, complex (..., 2, 2) -> (..., 4); a matrix outside the "
          "representation is projected onto it (least squares)." QC_CONVENTIONS);
    m.def("quat_to_real4",
          [](py::handle qo) {
              const Batch q = as_batch(qo, {4}, "q");
              DArray out = make_output(q.batch_shape, {4, 4});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < q.count; ++i) {
                  const auto r = quat_to_real4(read_quat(q, i, "q", Need::finite));
                  for (std::size_t n = 0; n < 16; ++n) o[16 * i + n] = r[n];
              }
              return out;
          },
          py::arg("q"),
          "The 4x4 real left-multiplication matrix L(q), (..., 4) -> (..., 4, 4), with L(a) @ b = a*b "
          "for b as a (w, x, y, z) column. Products map to products: L(a*b) = L(a) @ L(b)." QC_CONVENTIONS);
    m.def("real4_to_quat",
          [](py::handle mo) {
              const Batch mb = as_batch(mo, {4, 4}, "m");
              DArray out = make_output(mb.batch_shape, {4});
              double* o = out.mutable_data();
              for (std::size_t i = 0; i < mb.count; ++i) {
                  std::array<double, 16> r;
                  for (std::size_t n = 0; n < 16; ++n) r[n] = mb.data()[16 * i + n];
                  require(finite_problem(r), "m", mb.batch_shape, i);
                  write_quat(o, i, real4_to_quat(r));
              }
              require_finite_result(out, mb.batch_shape, 4);
              return out;
          },
          py::arg("m"),
          "Inverse of quat_to_real4, (..., 4, 4) -> (..., 4); a matrix outside the representation is "
          "projected onto it (least squares)." QC_CONVENTIONS);

    // ---- Euler angles ----
    m.def("euler_to_quat",
          [](py::handle angles, const std::string& order) {
              const EulerOrder o = parse_euler_order(order);
              return map_angles(angles, {4}, [o](double* out, std::size_t i, const Vec3& a) { write_quat(out, i, euler_to_quat(a, o)); });
          },
          py::arg("angles"), py::arg("order") = "XYZ",
          "Quaternion of Euler angles, (..., 3) -> (..., 4): q = qc*qb*qa for order 'ABC'. Continuous in "
          "the angles (no sign canonicalization: w may be negative)." QC_EULER QC_CONVENTIONS);
    m.def("euler_to_matrix",
          [](py::handle angles, const std::string& order) {
              const EulerOrder o = parse_euler_order(order);
              return map_angles(angles, {3, 3}, [o](double* out, std::size_t i, const Vec3& a) { write_mat3(out, i, euler_to_matrix(a, o)); });
          },
          py::arg("angles"), py::arg("order") = "XYZ",
          "Rotation matrix of Euler angles, (..., 3) -> (..., 3, 3): Rc @ Rb @ Ra for order 'ABC'."
          QC_EULER QC_CONVENTIONS);
    m.def("quat_to_euler",
          [](py::handle qo, const std::string& order, py::object compat) {
              const EulerOrder o = parse_euler_order(order);
              const Batch q = as_batch(qo, {4}, "q");
              if (compat.is_none()) {
                  DArray out = make_output(q.batch_shape, {3});
                  double* p = out.mutable_data();
                  for (std::size_t i = 0; i < q.count; ++i) write_vec(p, i, quat_to_euler(read_quat(q, i, "q", Need::nonzero), o));
                  return out;
              }
              const Batch ref = as_batch(compat, {3}, "compat");
              const Broadcast bc = broadcast({{"q", &q.batch_shape}, {"compat", &ref.batch_shape}});
              DArray out = make_output(bc.shape, {3});
              double* p = out.mutable_data();
              for (std::size_t i = 0; i < bc.count; ++i)
                  write_vec(p, i, quat_to_euler_compat(read_quat(q, bc.index(0, i), "q", Need::nonzero), o,
                                                       read_vec(ref, bc.index(1, i), "compat")));
              require_finite_result(out, bc.shape, 3);
              return out;
          },
          py::arg("q"), py::arg("order") = "XYZ", py::arg("compat") = py::none(),
          "Euler angles of q/|q|, (..., 4) -> (..., 3). Without compat: the middle angle in "
          "[-pi/2, pi/2], the others in [-pi, pi]; at gimbal lock the middle angle is exactly "
          "+-pi/2, the last angle 0 and the first takes all the rotation. With compat (..., 3, "
          "broadcast against q): the equivalent angles closest to compat by the sum of absolute "
          "differences, over both Euler solutions and 2 pi shifts of each angle (and, at gimbal lock, "
          "the whole family of equivalent angles): what Blender's compatible Euler approximates, as an "
          "exact minimum. Zero-length "
          "q raises ValueError." QC_EULER QC_CONVENTIONS);
    m.def("matrix_to_euler",
          [](py::handle mo, const std::string& order) {
              const EulerOrder o = parse_euler_order(order);
              const RotationMatrices ms(mo, "m", true);
              DArray out = make_output(ms.batch.batch_shape, {3});
              double* p = out.mutable_data();
              for (std::size_t i = 0; i < ms.batch.count; ++i) write_vec(p, i, matrix_to_euler(ms.at(i), o));
              return out;
          },
          py::arg("m"), py::arg("order") = "XYZ",
          "Euler angles of a rotation matrix, (..., 3, 3) or (..., 4, 4) -> (..., 3); the rotation "
          "nearest to m is used (scale and shear removed); ranges and gimbal lock as quat_to_euler "
          "without compat. Singular matrices and reflections raise ValueError." QC_EULER QC_CONVENTIONS);
    m.def("euler_compat",
          [](py::handle ao, py::handle ro, const std::string& order) {
              const EulerOrder o = parse_euler_order(order);
              const Batch a = as_batch(ao, {3}, "angles"), r = as_batch(ro, {3}, "ref");
              const Broadcast bc = broadcast({{"angles", &a.batch_shape}, {"ref", &r.batch_shape}});
              DArray out = make_output(bc.shape, {3});
              double* p = out.mutable_data();
              for (std::size_t i = 0; i < bc.count; ++i)
                  write_vec(p, i, euler_compat(read_vec(a, bc.index(0, i), "angles"), o, read_vec(r, bc.index(1, i), "ref")));
              require_finite_result(out, bc.shape, 3);
              return out;
          },
          py::arg("angles"), py::arg("ref"), py::arg("order") = "XYZ",
          "The Euler angles equivalent to angles (same rotation) closest to ref, (..., 3) x (..., 3) -> "
          "(..., 3): see quat_to_euler's compat. Ties keep the angles given." QC_BROADCAST QC_EULER QC_CONVENTIONS);
    m.def("euler_filter",
          [](py::handle ao, const std::string& order) {
              const EulerOrder o = parse_euler_order(order);
              const Batch a = as_batch(ao, {3}, "angles");
              DArray out = make_output(a.batch_shape, {3});
              double* p = out.mutable_data();
              const std::size_t n = a.batch_shape.empty() ? 1 : static_cast<std::size_t>(a.batch_shape.back());
              std::vector<Vec3> seq(n);
              for (std::size_t start = 0; start < a.count; start += n) {
                  for (std::size_t s = 0; s < n; ++s) seq[s] = read_vec(a, start + s, "angles");
                  euler_filter(seq.data(), n, o);
                  for (std::size_t s = 0; s < n; ++s) write_vec(p, start + s, seq[s]);
              }
              require_finite_result(out, a.batch_shape, 3);
              return out;
          },
          py::arg("angles"), py::arg("order") = "XYZ",
          "Remove flips and 2 pi jumps from a sequence of Euler angles, (N, 3) -> (N, 3) (or "
          "(..., N, 3): each sequence along axis -2 separately). The first triple is kept; each "
          "following one becomes the equivalent angles closest to the previous result (see "
          "euler_compat), so every orientation is unchanged." QC_EULER QC_CONVENTIONS);
    m.def("gimbal_distance",
          [](py::handle ao, const std::string& order) {
              const EulerOrder o = parse_euler_order(order);
              const Batch a = as_batch(ao, {3}, "angles");
              DArray out = make_output(a.batch_shape, {});
              double* p = out.mutable_data();
              for (std::size_t i = 0; i < a.count; ++i) p[i] = gimbal_distance(read_vec(a, i, "angles"), o);
              return out;
          },
          py::arg("angles"), py::arg("order") = "XYZ",
          "Distance (radians, in [0, pi/2]) of the order's middle angle b from gimbal lock "
          "(b = pi/2 mod pi), (..., 3) -> (...): atan2(|cos b|, |sin b|). 0 is locked." QC_EULER QC_CONVENTIONS);
    m.def("euler_middle_axis", [](const std::string& order) { return euler_middle_axis(parse_euler_order(order)); },
          py::arg("order"),
          "Index (0, 1, 2 = X, Y, Z) of the order's middle axis, whose angle +-pi/2 is gimbal lock." QC_EULER);
}

}  // namespace quatcurve::bindings
