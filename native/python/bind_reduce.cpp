// Bindings of key reduction (reduce.hpp). Bindings only bind: arrays in, the native reducer, arrays
// out; every check and formula lives in native/src/reduce*.cpp (and blender_eval.cpp).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "quatcurve/bound.hpp"
#include "quatcurve/channels.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/euler.hpp"
#include "quatcurve/fit.hpp"
#include "quatcurve/reduce.hpp"
#include "quatcurve/skeleton.hpp"
#include "quatcurve/slerp_keys.hpp"

namespace quatcurve::bindings {

namespace {

// (N, 4) axis-angle rows (angle, x, y, z).
std::vector<Vec4> read_vec4_rows(py::handle obj, std::size_t n) {
    const Batch a = read_rows(obj, 4, "values", n);
    std::vector<Vec4> out(n);
    for (std::size_t k = 0; k < n; ++k) {
        const double* p = a.data() + 4 * k;
        out[k] = Vec4(p[0], p[1], p[2], p[3]);
    }
    return out;
}

DArray vector_array(const std::vector<double>& v) {
    DArray out(static_cast<py::ssize_t>(v.size()));
    std::copy(v.begin(), v.end(), out.mutable_data());
    return out;
}

DArray pair_array(const std::vector<double>& v) {
    DArray out({static_cast<py::ssize_t>(v.size() / 2), static_cast<py::ssize_t>(2)});
    std::copy(v.begin(), v.end(), out.mutable_data());
    return out;
}

// LINEAR: the indices (synchronized) or one index array per channel; BEZIER (or detailed): the
// ReducedKeys.
py::object linear_or_full(const ReducedKeys& r, bool synchronized, bool detailed) {
    if (detailed || r.interpolation == KeyInterpolation::BEZIER) return py::cast(r);
    if (synchronized) return index_array(r.channels[0].indices);
    py::list per_channel;
    for (const ReducedChannel& ch : r.channels) per_channel.append(index_array(ch.indices));
    return per_channel;
}

// One F-curve's keys from (frames, values) or (frames, values, handle_left, handle_right): 1-D
// frames and values, (K, 2) handles (None for LINEAR). Named "channels[c]" in messages; the keys
// themselves are checked by the native side (check_fcurve_keys).
FCurveKeys read_fcurve_keys(py::handle item, std::size_t c) {
    const std::string name = "channels[" + std::to_string(c) + "]";
    if (!py::isinstance<py::sequence>(item) || py::isinstance<py::str>(item))
        throw py::type_error(name + ": expected (frames, values[, handle_left, handle_right])");
    const py::sequence parts = py::reinterpret_borrow<py::sequence>(item);
    if (parts.size() != 2 && parts.size() != 4)
        throw py::value_error(name + ": expected (frames, values[, handle_left, handle_right]), got " +
                              std::to_string(parts.size()) + " items");
    FCurveKeys keys;
    keys.frames = read_times(parts[0]);
    const std::vector<double> values = read_times(parts[1]);
    if (values.size() != keys.frames.size())
        throw py::value_error(name + ": " + std::to_string(values.size()) + " values for " +
                              std::to_string(keys.frames.size()) + " frames");
    keys.values = values;
    for (std::size_t side = 0; parts.size() == 4 && side < 2; ++side) {
        if (parts[2 + side].is_none()) continue;
        const Batch h = as_batch(parts[2 + side], {2}, side ? "handle_right" : "handle_left");
        if (h.batch_shape.size() != 1 || h.count != keys.frames.size())
            throw py::value_error(name + (side ? ".handle_right" : ".handle_left") + ": expected shape (" +
                                  std::to_string(keys.frames.size()) + ", 2), got " + shape_string(h.array));
        (side ? keys.handle_right : keys.handle_left).assign(h.data(), h.data() + 2 * h.count);
    }
    return keys;
}

std::vector<double> read_channel_rows(py::handle values, const RotationMode& mode, std::size_t n) {
    const Batch v = read_rows(values, static_cast<py::ssize_t>(channel_count(mode)), "values", n);
    return std::vector<double>(v.data(), v.data() + v.count * channel_count(mode));
}

DArray pairs_array(const std::vector<std::pair<double, double>>& v) {
    DArray a({static_cast<py::ssize_t>(v.size()), static_cast<py::ssize_t>(2)});
    for (std::size_t i = 0; i < v.size(); ++i) {
        a.mutable_data()[2 * i] = v[i].first;
        a.mutable_data()[2 * i + 1] = v[i].second;
    }
    return a;
}

}  // namespace

void bind_reduce(py::module_& m) {
    py::class_<ReducedChannel>(m, "ReducedChannel",
                               "The keys of one F-curve as Blender stores them (float32 values).")
        .def_property_readonly("indices", [](const ReducedChannel& c) { return index_array(c.indices); },
                               "kept sample indices (int64), first and last included")
        .def_property_readonly("frames", [](const ReducedChannel& c) { return vector_array(c.frames); },
                               "key frames (float32 values as float64)")
        .def_property_readonly("values", [](const ReducedChannel& c) { return vector_array(c.values); },
                               "key values (float32 values as float64)")
        .def_property_readonly("handle_left",
                               [](const ReducedChannel& c) { return pair_array(c.handle_left); },
                               "(K, 2) absolute (frame, value) left handles; (0, 2) for LINEAR")
        .def_property_readonly("handle_right",
                               [](const ReducedChannel& c) { return pair_array(c.handle_right); },
                               "(K, 2) absolute (frame, value) right handles; (0, 2) for LINEAR")
        .def("__len__", [](const ReducedChannel& c) { return c.indices.size(); })
        .def("__repr__", [](const ReducedChannel& c) {
            return "<ReducedChannel " + std::to_string(c.indices.size()) + " keys>";
        });

    py::class_<ReducedKeys>(m, "ReducedKeys",
                            "Result of a BEZIER reduction: per-channel keys and handles (w, x, y, z "
                            "or X, Y, Z). Handles are broken at keys: set handle types to 'FREE'.")
        .def_property_readonly("interpolation",
                               [](const ReducedKeys& r) { return key_interpolation_name(r.interpolation); })
        .def_readonly("synchronized", &ReducedKeys::synchronized,
                      "True when every channel has the same key indices")
        .def_readonly("channels", &ReducedKeys::channels)
        .def_readonly("max_error", &ReducedKeys::max_error,
                      "largest error (radians) over all input samples under Blender's evaluation")
        .def_property_readonly("key_count", &ReducedKeys::key_count,
                               "keys summed over channels (Blender's keyframe_points)")
        .def("__repr__", [](const ReducedKeys& r) {
            return std::string("<ReducedKeys ") + key_interpolation_name(r.interpolation) + ", " +
                   std::to_string(r.channels.size()) + " channels, " + std::to_string(r.key_count()) +
                   " keys, max_error " + std::to_string(r.max_error) + " rad>";
        });

    m.def(
        "reduce_keys",
        [](py::handle times, py::handle quats, double tolerance, const std::string& interpolation,
           bool synchronized, bool detailed) {
            const KeyInterpolation ipo = parse_key_interpolation(interpolation);
            const std::vector<double> t = read_times(times);
            const Batch q = read_rows(quats, 4, "quats", t.size());
            std::vector<Quat> qs(t.size());
            for (std::size_t k = 0; k < t.size(); ++k) qs[k] = from_wxyz(q.data() + 4 * k);
            ReducedKeys r;
            {
                py::gil_scoped_release release;
                r = reduce_keys(t, qs, tolerance, ipo, synchronized);
            }
            return linear_or_full(r, synchronized, detailed);
        },
        py::arg("times"), py::arg("quats"), py::arg("tolerance"), py::arg("interpolation") = "LINEAR",
        py::arg("synchronized") = true, py::kw_only(), py::arg("detailed") = false,
        R"doc(Reduce dense quaternion samples to the fewest keys Blender can evaluate within `tolerance`.

times: (N,) strictly increasing frames; quats: (N, 4) (w, x, y, z), kept as given (pass a
hemisphere-continuous sequence: a sign flip between samples forces keys on both sides);
tolerance: radians (geodesic angle, sign-invariant), >= 0.

Blender's evaluation of the kept keys — each channel linear (LINEAR) or Bezier with the returned
handles (BEZIER), in float32, then normalized — stays within `tolerance` of every input sample
(verified by emulating Blender's F-curve evaluation). The first and last samples are always kept;
tolerance 0 keeps every sample.

Returns, for LINEAR: the kept indices (int64 array) when synchronized, else a list of four index
arrays (w, x, y, z). For BEZIER: a ReducedKeys with per-channel indices, frames, values,
handle_left/handle_right (K, 2) absolute (frame, value), max_error and key_count.
detailed=True returns the ReducedKeys for LINEAR too (empty handles), e.g. for its max_error.
synchronized=False lets each channel keep its own keys where that saves keys.)doc");

    m.def(
        "reduce_keys_euler",
        [](py::handle times, py::handle angles, const std::string& order, double tolerance,
           const std::string& interpolation, bool synchronized, bool detailed) {
            const KeyInterpolation ipo = parse_key_interpolation(interpolation);
            const EulerOrder ord = parse_euler_order(order);
            const std::vector<double> t = read_times(times);
            const Batch a = read_rows(angles, 3, "angles", t.size());
            std::vector<Vec3> as(t.size());
            for (std::size_t k = 0; k < t.size(); ++k) {
                const double* p = a.data() + 3 * k;
                as[k] = Vec3(p[0], p[1], p[2]);
            }
            ReducedKeys r;
            {
                py::gil_scoped_release release;
                r = reduce_keys_euler(t, as, ord, tolerance, ipo, synchronized);
            }
            return linear_or_full(r, synchronized, detailed);
        },
        py::arg("times"), py::arg("angles"), py::arg("order"), py::arg("tolerance"),
        py::arg("interpolation") = "LINEAR", py::arg("synchronized") = true, py::kw_only(),
        py::arg("detailed") = false,
        R"doc(Reduce dense Euler samples (N, 3) (radians about X, Y, Z; Blender order, 'XYZ' = Rz·Ry·Rx).

The bound is on the rotation Blender builds from the three evaluated angle channels. Angles are
kept as given (pass a filtered, continuous sequence). Returns as reduce_keys, with three channels
(X, Y, Z).)doc");

    m.def(
        "reduce_keys_axis_angle",
        [](py::handle times, py::handle values, double tolerance, const std::string& interpolation,
           bool synchronized, bool detailed) {
            const KeyInterpolation ipo = parse_key_interpolation(interpolation);
            const std::vector<double> t = read_times(times);
            const std::vector<Vec4> vs = read_vec4_rows(values, t.size());
            ReducedKeys r;
            {
                py::gil_scoped_release release;
                r = reduce_keys_axis_angle(t, vs, tolerance, ipo, synchronized);
            }
            return linear_or_full(r, synchronized, detailed);
        },
        py::arg("times"), py::arg("values"), py::arg("tolerance"), py::arg("interpolation") = "LINEAR",
        py::arg("synchronized") = true, py::kw_only(), py::arg("detailed") = false,
        R"doc(Reduce dense axis-angle samples (N, 4) (angle in radians, axis x, y, z as Blender's
rotation_axis_angle; the axis need not be unit).

The bound is on the rotation Blender builds from the four evaluated channels (the axis normalized; a
zero axis is no rotation). Values are kept as given (pass continuous channels, e.g. from
quats_to_channels(..., 'AXIS_ANGLE')). Returns as reduce_keys, with four channels (angle, x, y, z).)doc");

    m.def(
        "fit_keys",
        [](py::handle times, py::handle values, py::handle forced, double tolerance, const std::string& mode,
           const std::string& interpolation, bool synchronized, double min_gap) {
            const KeyInterpolation ipo = parse_key_interpolation(interpolation);
            const std::vector<double> t = read_times(times);
            const std::vector<std::size_t> f = read_indices(forced, "forced");
            ReducedKeys r;
            if (mode == "QUATERNION") {
                const Batch q = read_rows(values, 4, "values", t.size());
                std::vector<Quat> qs(t.size());
                for (std::size_t k = 0; k < t.size(); ++k) qs[k] = from_wxyz(q.data() + 4 * k);
                py::gil_scoped_release release;
                r = fit_keys(t, qs, f, tolerance, ipo, synchronized, min_gap);
            } else if (mode == "AXIS_ANGLE") {
                const std::vector<Vec4> vs = read_vec4_rows(values, t.size());
                py::gil_scoped_release release;
                r = fit_keys_axis_angle(t, vs, f, tolerance, ipo, synchronized, min_gap);
            } else {
                const EulerOrder ord = parse_euler_order(mode);
                const Batch a = read_rows(values, 3, "values", t.size());
                std::vector<Vec3> as(t.size());
                for (std::size_t k = 0; k < t.size(); ++k) as[k] = Vec3(a.data()[3 * k], a.data()[3 * k + 1], a.data()[3 * k + 2]);
                py::gil_scoped_release release;
                r = fit_keys_euler(t, as, ord, f, tolerance, ipo, synchronized, min_gap);
            }
            return r;
        },
        py::arg("times"), py::arg("values"), py::arg("forced"), py::arg("tolerance"), py::kw_only(),
        py::arg("mode") = "QUATERNION", py::arg("interpolation") = "BEZIER", py::arg("synchronized") = false,
        py::arg("min_gap") = 0.01,
        R"doc(Fit keys through given ones: the reducer with forced keys (an animator's own keys).

times: (N,) strictly increasing frames; values: (N, 4) quaternions (w, x, y, z) for mode='QUATERNION',
(N, 3) Euler angles (radians about X, Y, Z) for mode = an Euler order ('XYZ', ...), or (N, 4) Blender
axis-angle channels (angle in radians, axis x, y, z; the axis normalized as Blender does) for
mode='AXIS_ANGLE' (pass continuous channels: an angle jump above pi or an axis turning over between
samples forces keys on both sides); forced: sample
indices (increasing) that must be keys of every channel, values as given. Keys are inserted between
them, at samples at least min_gap frames from every forced key, until Blender's evaluation of the
F-curves stays within `tolerance` (radians) of every sample. Returns a ReducedKeys (per channel:
indices, frames, values, handle_left/handle_right (K, 2)); max_error is what Blender's evaluation
reaches (emulated), above `tolerance` only where no key could be inserted.)doc");
    py::class_<PlaybackBound>(m, "PlaybackBound",
                              "What prove_playback (and the fit) proved of Blender's playback against a curve "
                              "over a whole time range (bound.hpp)")
        .def_readonly("bound", &PlaybackBound::bound,
                      "radians: the angle stays within it at EVERY time of the range, whatever the verdict")
        .def_readonly("max_evaluated", &PlaybackBound::max_evaluated, "radians: the largest angle at an evaluated time")
        .def_readonly("worst_time", &PlaybackBound::worst_time, "where `bound` is reached (a frame)")
        .def_property_readonly("violations", [](const PlaybackBound& b) { return vector_array(b.violations); },
                               "evaluated frames where the angle is above the tolerance")
        .def_property_readonly("unproven",
                               [](const PlaybackBound& b) {
                                   DArray a({static_cast<py::ssize_t>(b.unproven.size()), static_cast<py::ssize_t>(2)});
                                   for (std::size_t i = 0; i < b.unproven.size(); ++i) {
                                       a.mutable_data()[2 * i] = b.unproven[i].first;
                                       a.mutable_data()[2 * i + 1] = b.unproven[i].second;
                                   }
                                   return a;
                               },
                               "(M, 2) frame intervals shorter than min_step not proved within the tolerance")
        .def_readonly("evaluations", &PlaybackBound::evaluations)
        .def_property_readonly("proven", &PlaybackBound::proven, "within the tolerance at every time of the range")
        .def("__repr__", [](const PlaybackBound& b) {
            return std::string("<PlaybackBound ") + (b.proven() ? "proven" : "NOT proven") + ", bound " +
                   std::to_string(b.bound) + " rad at frame " + std::to_string(b.worst_time) + ">";
        });

    py::class_<KeyFit>(m, "KeyFit", "Result of fit_through_keys")
        .def_property_readonly("times", [](const KeyFit& f) { return vector_array(f.times); },
                               "the samples: every 1/subframes frame and every key, and the times the proof added")
        .def_property_readonly("forced", [](const KeyFit& f) { return index_array(f.forced); },
                               "each key's index in times (int64)")
        .def_readonly("keys", &KeyFit::keys, "the fitted keys (ReducedKeys; max_error is at `times` only)")
        .def_property_readonly("switches",
                               [](const KeyFit& f) {
                                   py::list out;
                                   for (const EulerSwitch& s : f.switches) out.append(py::make_tuple(s.segment, s.frame));
                                   return out;
                               },
                               "(key segment, frame) of every change of Euler branch between keys")
        .def_readonly("proof", &KeyFit::proof, "PlaybackBound of Blender's playback of `keys` against the curve")
        .def_property_readonly("segment_bounds",
                               [](const KeyFit& f) {
                                   std::vector<double> b;
                                   for (const PlaybackBound& p : f.segment_proofs) b.push_back(p.bound);
                                   return vector_array(b);
                               },
                               "(K-1,) the proved bound of each key segment (radians)")
        .def_property_readonly("curve", [](const KeyFit& f) -> py::object {
                                   if (!f.curve) return py::none();
                                   return py::cast(Curve(*f.curve));
                               },
                               "a copy of the curve the keys were fitted to (None for a default KeyFit)")
        .def_property_readonly("key_values",
                               [](const KeyFit& f) {
                                   const std::size_t K = f.key_frames.size(), C = K ? f.key_values.size() / K : 0;
                                   DArray a({static_cast<py::ssize_t>(K), static_cast<py::ssize_t>(C)});
                                   std::copy(f.key_values.begin(), f.key_values.end(), a.mutable_data());
                                   return a;
                               },
                               "(K, C) the keys' channel values as the fit writes them")
        .def_readonly("refitted", &KeyFit::refitted,
                      "key segments this call fitted; the others are the previous fit's (fit_through_keys' previous)")
        .def("__repr__", [](const KeyFit& f) {
            return "<KeyFit " + std::to_string(f.times.size()) + " samples, " + std::to_string(f.keys.key_count()) +
                   " keys, bound " + std::to_string(f.proof.bound) + " rad>";
        });

    m.def(
        "fit_through_keys",
        [](const Curve& curve, py::handle key_frames, py::handle key_values, const std::string& mode_name,
           int subframes, double tolerance, double min_gap, const KeyFit* previous) {
            const RotationMode mode = parse_rotation_mode(mode_name);
            const std::vector<double> kf = read_times(key_frames);
            const Batch v = read_rows(key_values, static_cast<py::ssize_t>(channel_count(mode)), "key_values", kf.size());
            const std::vector<double> kv(v.data(), v.data() + v.count * channel_count(mode));
            py::gil_scoped_release release;
            return fit_through_keys(curve, kf, kv, mode, subframes, tolerance, min_gap, previous);
        },
        py::arg("curve"), py::arg("key_frames"), py::arg("key_values"), py::arg("mode"), py::kw_only(),
        py::arg("subframes"), py::arg("tolerance"), py::arg("min_gap") = 0.01, py::arg("previous") = nullptr,
        R"doc(Fit Blender F-curves through an animator's keys along `curve` (the method through them), in one
call without the GIL: a KeyFit.

key_frames: (K,) increasing, K >= 2; key_values: (K, 4|3|4) channel values of `mode` ('QUATERNION', an
Euler order, 'AXIS_ANGLE') as the fit writes them (quaternion keys with the sign the curve reaches them
with); tolerance: radians, > 0. The channel values between keys follow the curve and join the keys
(quaternions scaled by the keys' norms, Euler angles continuous with one change of branch where the
path needs it, beside a key at gimbal lock or nearest the lock, axis-angle by axis_angle_span with the axis length interpolated); fit_keys inserts
as few BEZIER keys as 90% of `tolerance` needs, min_gap frames from the keys; then the playback is
proved against the curve at every instant between the first and the last key (KeyFit.proof), and
the times that fail become samples of another round.

previous: the last KeyFit of the same target (a refit after an edit): the key segments whose keys
and curve are unchanged keep its keys, handles and proof; only the others are fitted and proved
(KeyFit.refitted counts them). Nothing is reused when mode, subframes, tolerance or min_gap differ.)doc");

    m.def(
        "prove_playback",
        [](const Curve& curve, const std::vector<ReducedChannel>& channels, const std::string& interpolation,
           const std::string& mode_name, py::handle times, double tolerance, double min_step) {
            const RotationMode mode = parse_rotation_mode(mode_name);
            const KeyInterpolation ipo = parse_key_interpolation(interpolation);
            const std::vector<double> t = read_times(times);
            std::vector<FCurveKeys> ch(channels.begin(), channels.end());
            py::gil_scoped_release release;
            const PlaybackMotion playback(std::move(ch), ipo, mode);
            return prove_within(playback, CurveMotion(curve), t, tolerance, min_step);
        },
        py::arg("curve"), py::arg("channels"), py::arg("interpolation"), py::arg("mode"), py::arg("times"),
        py::arg("tolerance"), py::kw_only(), py::arg("min_step") = 1.0 / 1024.0,
        R"doc(Prove that Blender's playback of `channels` (ReducedChannel list, e.g. ReducedKeys.channels, in
`mode`) stays within `tolerance` radians of `curve` at every time from times[0] to times[-1]: the
angle at `times` (sorted), and between them a bound from both motions' speed bounds, halving
intervals down to min_step frames (bound.hpp). Returns a PlaybackBound.)doc");

    py::class_<ProvedKeys>(m, "ProvedKeys",
                           "Result of reduce_keys_proved and reduce_curve_proved: the reduced keys and the proof "
                           "of their playback against the reference at every instant (reduce.hpp)")
        .def_readonly("keys", &ProvedKeys::keys, "the reduced keys (ReducedKeys; max_error is at `times` only)")
        .def_readonly("proof", &ProvedKeys::proof,
                      "PlaybackBound of the reduced keys' playback against the reference over every proved span")
        .def_property_readonly("copied", [](const ProvedKeys& r) { return pairs_array(r.copied); },
                               "(M, 2) frame spans [f0, f1] whose keys are the original's, bit for bit: around the "
                               "original's own quaternion sign flips, which Blender swings through (a key at a frame "
                               "in [f0, f1) has copied_interpolation, every other key keys.interpolation)")
        .def_property_readonly("copied_interpolation",
                               [](const ProvedKeys& r) { return std::string(key_interpolation_name(r.copied_interpolation)); },
                               "'LINEAR' or 'BEZIER': the interpolation of the keys in the copied spans (the original's)")
        .def_property_readonly("times", [](const ProvedKeys& r) { return vector_array(r.times); },
                               "the samples of the last reduction: the given ones and those added (midpoints and the "
                               "proof's failing times)")
        .def_readonly("rounds", &ProvedKeys::rounds, "rounds made (1: the first reduction was proved)")
        .def("__repr__", [](const ProvedKeys& r) {
            return std::string("<ProvedKeys ") + std::to_string(r.keys.key_count()) + " keys, " +
                   (r.proof.proven() ? "proven" : "NOT proven") + ", bound " + std::to_string(r.proof.bound) +
                   " rad, " + std::to_string(r.copied.size()) + " copied, " + std::to_string(r.rounds) +
                   " rounds>";
        });

    m.def(
        "reduce_keys_proved",
        [](py::sequence channels, const std::string& channel_interpolation, const std::string& mode_name,
           py::handle times, py::handle values, double tolerance, const std::string& interpolation,
           bool synchronized, bool one_key_channels) {
            const RotationMode mode = parse_rotation_mode(mode_name);
            const KeyInterpolation original_ipo = parse_key_interpolation(channel_interpolation);
            const KeyInterpolation ipo = parse_key_interpolation(interpolation);
            std::vector<FCurveKeys> original;
            for (std::size_t c = 0; c < channels.size(); ++c) original.push_back(read_fcurve_keys(channels[c], c));
            const std::vector<double> t = read_times(times);
            const std::vector<double> v = read_channel_rows(values, mode, t.size());
            py::gil_scoped_release release;
            return reduce_keys_proved(original, original_ipo, mode, t, v, tolerance, ipo, synchronized,
                                      one_key_channels);
        },
        py::arg("channels"), py::arg("channel_interpolation"), py::arg("mode"), py::arg("times"), py::arg("values"),
        py::arg("tolerance"), py::arg("interpolation") = "BEZIER", py::arg("synchronized") = false, py::kw_only(),
        py::arg("one_key_channels") = true,
        R"doc(Reduce a rotation's samples and prove the reduced keys against the original keys' own playback at
every instant, in one call without the GIL: a ProvedKeys.

channels: the original F-curves of `mode` ('QUATERNION', an Euler order, 'AXIS_ANGLE'), one per channel
in order, each (frames, values) or (frames, values, handle_left, handle_right) as Blender stores them
(handles (K, 2) absolute (frame, value), required for BEZIER); channel_interpolation: 'LINEAR' or
'BEZIER', of every segment of every channel. times: (N,) increasing frames; values: (N, C) Blender's
evaluation of the channels there (quaternions are made hemisphere-continuous first); tolerance:
radians, >= 0.

The samples are reduced as reduce_keys* does at 93% of `tolerance` (90% below 0.01°); Blender's playback of the result
is proved against the original's playback (blender_evaluate) at every time from times[0] to
times[-1] (prove_playback's method); the times that fail become samples of another round (the
original's values there; keys between the given frames only where keys on them cannot meet those), in
which the keys are repaired where those samples fail or the samples reduced afresh, up to 8 rounds. Where the original's stored quaternions flip sign between two samples (Blender swings
through the flip), the original's keys around it are copied bit for bit (ProvedKeys.copied, with the
original's interpolation and handles) and the pieces between are reduced on their own: the bound holds
from times[0] to times[-1], the flips included. Where the proof still fails after every round, the
original's keys are copied there too (spans growing until the pieces between are proved), and where
it would keep more keys than the original or stay unproved, the result is the original's keys whole
(bound 0). Tolerance 0 keeps every sample and proves nothing
between them (bound inf).

one_key_channels: where the keys are the whole result (no copied span), not synchronized, a channel
that one value meets at every sample keeps one key, at times[0], with flat handles (Blender plays it
at every frame); False keeps at least the first and last key on every channel (a loop's period, whose
Cycles modifier repeats each channel's own key range).)doc");

    m.def(
        "reduce_curve_proved",
        [](const Curve& curve, const std::string& mode_name, py::handle times, py::handle values, double tolerance,
           const std::string& interpolation, bool synchronized, bool one_key_channels) {
            const RotationMode mode = parse_rotation_mode(mode_name);
            const KeyInterpolation ipo = parse_key_interpolation(interpolation);
            const std::vector<double> t = read_times(times);
            const std::vector<double> v = read_channel_rows(values, mode, t.size());
            py::gil_scoped_release release;
            return reduce_curve_proved(curve, mode, t, v, tolerance, ipo, synchronized, one_key_channels);
        },
        py::arg("curve"), py::arg("mode"), py::arg("times"), py::arg("values"), py::arg("tolerance"),
        py::arg("interpolation") = "BEZIER", py::arg("synchronized") = false, py::kw_only(),
        py::arg("one_key_channels") = true,
        R"doc(Reduce samples of `curve` and prove the reduced keys against the curve at every instant: a
ProvedKeys (as reduce_keys_proved, the reference being the curve; nothing is copied).

times: (N,) increasing frames; values: (N, C) the curve's rotations there as channel values of `mode`
(quats_to_channels, with any reference; kept as given, quaternions made hemisphere-continuous); a
sample the proof adds takes the curve's rotation as channel values continuous with the sample before.)doc");

    m.def(
        "convert_keys_proved",
        [](py::sequence channels, const std::string& channel_interpolation, const std::string& from_name,
           const std::string& to_name, py::handle times, py::handle values, py::handle forced, double tolerance,
           double min_gap) {
            const RotationMode from = parse_rotation_mode(from_name), to = parse_rotation_mode(to_name);
            const KeyInterpolation original_ipo = parse_key_interpolation(channel_interpolation);
            std::vector<FCurveKeys> original;
            for (std::size_t c = 0; c < channels.size(); ++c) original.push_back(read_fcurve_keys(channels[c], c));
            const std::vector<double> t = read_times(times);
            const std::vector<double> v = read_channel_rows(values, to, t.size());
            const std::vector<std::size_t> f = read_indices(forced, "forced");
            py::gil_scoped_release release;
            return convert_keys_proved(original, original_ipo, from, to, t, v, f, tolerance, min_gap);
        },
        py::arg("channels"), py::arg("channel_interpolation"), py::arg("from_mode"), py::arg("to_mode"),
        py::arg("times"), py::arg("values"), py::arg("forced"), py::arg("tolerance"), py::arg("min_gap") = 0.01,
        R"doc(Convert a rotation's keys to another rotation mode, proved against the original keys' own playback at
every instant, in one call without the GIL: a ProvedKeys (BEZIER keys per channel of `to_mode`).

channels: the original F-curves of `from_mode`, one per channel in order, as reduce_keys_proved takes
them; channel_interpolation: 'LINEAR' or 'BEZIER', of every segment of every channel. times: (N,)
increasing frames; values: (N, C) Blender's playback there as `to_mode`'s channels (quats_to_channels,
continuous); forced: (F,) increasing indices into times that stay keys (the animator's frames), no
inserted key within min_gap frames of them; tolerance: radians, > 0.

Reduced at 93% of `tolerance` at the samples (90% below 0.01°) and proved between them as reduce_keys_proved does
(the failing times become samples, up to 8 rounds); ProvedKeys.proof.bound holds at every time
from times[0] to times[-1].)doc");

    py::class_<SlerpKeys>(m, "SlerpKeys", "Result of reduce_slerp: the kept samples as glTF LINEAR (slerp) keys.")
        .def_property_readonly("indices", [](const SlerpKeys& r) { return index_array(r.indices); },
                               "kept sample indices (int64), increasing; first and last included")
        .def_property_readonly("quats",
                               [](const SlerpKeys& r) {
                                   DArray a({static_cast<py::ssize_t>(r.quats.size()), static_cast<py::ssize_t>(4)});
                                   for (std::size_t k = 0; k < r.quats.size(); ++k)
                                       to_wxyz(r.quats[k], a.mutable_data() + 4 * k);
                                   return a;
                               },
                               "(K, 4) kept samples (w, x, y, z), normalized, each in the hemisphere of the one before")
        .def_readonly("max_error", &SlerpKeys::max_error,
                      "largest angle (radians) between a sample and the keys' slerp")
        .def("__len__", [](const SlerpKeys& r) { return r.indices.size(); })
        .def("__repr__", [](const SlerpKeys& r) {
            return "<SlerpKeys " + std::to_string(r.indices.size()) + " keys, max_error " +
                   std::to_string(r.max_error) + " rad>";
        });

    m.def(
        "reduce_slerp",
        [](py::handle times, py::handle quats, double tolerance, bool cyclic) {
            const std::vector<double> t = read_times(times);
            const Batch q = read_rows(quats, 4, "quats", t.size());
            std::vector<Quat> qs(t.size());
            for (std::size_t k = 0; k < t.size(); ++k) qs[k] = from_wxyz(q.data() + 4 * k);
            py::gil_scoped_release release;
            return reduce_slerp(t, qs, tolerance, cyclic);
        },
        py::arg("times"), py::arg("quats"), py::arg("tolerance"), py::kw_only(), py::arg("cyclic") = false,
        R"doc(The fewest glTF LINEAR rotation keys (slerp) among dense samples, within `tolerance`.

times: (N,) strictly increasing (any unit); quats: (N, 4) (w, x, y, z), nonzero; tolerance:
radians (geodesic angle, sign-invariant), >= 0. Greedy key choice; every kept segment is verified
on every sample inside it: glTF's slerp between consecutive keys (gltf_slerp) at each sample's time
stays within `tolerance` of the sample. Samples are compared as given: pass them as the file stores
them (float32) to verify what a reader plays. Returns a SlerpKeys (indices, quats, max_error).
cyclic=True: the samples are one period of a loop, the last sample the first rotation (refused
otherwise, naming both samples and the angle); the last key is then the first key's rotation.)doc");

    py::class_<ProvedSlerpKeys>(m, "ProvedSlerpKeys",
                                "Result of reduce_slerp_proved: slerp keys and the proof of their slerp against the "
                                "reference at every instant (slerp_keys.hpp)")
        .def_property_readonly("times", [](const ProvedSlerpKeys& r) { return vector_array(r.times); },
                               "the samples of the last round: the given ones and those the proof added")
        .def_readonly("keys", &ProvedSlerpKeys::keys, "SlerpKeys; indices into `times`")
        .def_property_readonly("key_times",
                               [](const ProvedSlerpKeys& r) {
                                   std::vector<double> t;
                                   for (std::size_t i : r.keys.indices) t.push_back(r.times[i]);
                                   return vector_array(t);
                               },
                               "the keys' times (the samples at keys.indices)")
        .def_readonly("proof", &ProvedSlerpKeys::proof,
                      "PlaybackBound of the keys' slerp against the reference over [times[0], times[-1]]")
        .def_property_readonly("excluded", [](const ProvedSlerpKeys& r) { return pairs_array(r.excluded); },
                               "(M, 2) sample intervals left out of the proof: a playback's own quaternion sign "
                               "flips, where Blender turns through them and the keys take the short way")
        .def_readonly("rounds", &ProvedSlerpKeys::rounds, "reductions made (1: the first was proved)")
        .def("__repr__", [](const ProvedSlerpKeys& r) {
            return "<ProvedSlerpKeys " + std::to_string(r.keys.indices.size()) + " keys, " +
                   (r.proof.proven() ? "proven" : "NOT proven") + ", bound " + std::to_string(r.proof.bound) +
                   " rad, " + std::to_string(r.rounds) + " rounds>";
        });

    m.def(
        "reduce_slerp_proved",
        [](const Curve& curve, py::handle times, double tolerance, bool cyclic, double file_unit) {
            const std::vector<double> t = read_times(times);
            py::gil_scoped_release release;
            return reduce_slerp_proved(CurveMotion(curve), t, tolerance, cyclic, file_unit);
        },
        py::arg("curve"), py::arg("times"), py::arg("tolerance"), py::kw_only(), py::arg("cyclic") = false,
        py::arg("file_unit") = 0.0);
    m.def(
        "reduce_slerp_proved",
        [](py::sequence channels, const std::string& channel_interpolation, const std::string& mode_name,
           py::handle times, double tolerance, bool cyclic, double file_unit) {
            const RotationMode mode = parse_rotation_mode(mode_name);
            const KeyInterpolation ipo = parse_key_interpolation(channel_interpolation);
            std::vector<FCurveKeys> original;
            for (std::size_t c = 0; c < channels.size(); ++c) original.push_back(read_fcurve_keys(channels[c], c));
            const std::vector<double> t = read_times(times);
            py::gil_scoped_release release;
            const PlaybackMotion playback(std::move(original), ipo, mode);
            std::vector<std::pair<double, double>> flips;
            if (mode.kind == RotationMode::Kind::quaternion) flips = quaternion_flips(playback, t);
            return reduce_slerp_proved(playback, t, tolerance, cyclic, file_unit, std::move(flips));
        },
        py::arg("channels"), py::arg("channel_interpolation"), py::arg("mode"), py::arg("times"), py::arg("tolerance"),
        py::kw_only(), py::arg("cyclic") = false, py::arg("file_unit") = 0.0,
        R"doc(glTF LINEAR (slerp) keys proved within `tolerance` radians of a reference at EVERY time from
times[0] to times[-1], not only at the samples: a ProvedSlerpKeys.

reduce_slerp_proved(curve, times, tolerance): the reference is a Curve (a method through keys).
reduce_slerp_proved(channels, channel_interpolation, mode, times, tolerance): the reference is
Blender's playback of a rotation's F-curves (as reduce_keys_proved takes them: one (frames, values[,
handle_left, handle_right]) per channel of `mode`, every segment 'LINEAR' or 'BEZIER'); the sample
intervals across which its quaternion channels flip hemisphere are left out (ProvedSlerpKeys.excluded:
Blender turns through the flip there, the keys take the short way).

times: (N >= 2,) increasing frames, the samples to start from. The reference there is reduced by
reduce_slerp at 90% of the tolerance; the keys' slerp is proved against the reference between the
samples (prove_within, bound.hpp); the times that fail become samples and the reduction runs again
(at most 8 rounds). The keys sit on samples (ProvedSlerpKeys.key_times); the proof's bound holds at
every instant whatever its verdict. Slerp is bi-invariant: keys A·q·B (an exporter's axis and
parent maps) play the same motion turned, within the same bound. cyclic: as reduce_slerp. file_unit
> 0 (seconds per frame): every sample the proof adds is a time a file of float32 seconds stores exactly
(float32(t·file_unit)/file_unit), as the given times should be.)doc");

    py::class_<SlerpBone>(m, "SlerpBone", R"doc(One bone's glTF rotation sampler for Skeleton.reduce_slerp: the times its keys are chosen
among, and what they are held to.

SlerpBone(times, reference=curve | (channels, channel_interpolation, mode), cyclic=False,
file_unit=0.0): keys proved against the reference at every instant (reduce_slerp_proved; a
playback's quaternion sign flips left out, as there). SlerpBone(times, samples=(N, 4)): keys held
at the samples only (reduce_slerp), the proof unproven. times: (N >= 2,) increasing frames.)doc")
        .def(py::init([](py::handle times, py::object reference, py::object samples, bool cyclic, double file_unit) {
                 SlerpBone bone;
                 bone.times = read_times(times);
                 bone.cyclic = cyclic;
                 bone.file_unit = file_unit;
                 if (!reference.is_none() && !samples.is_none())
                     throw py::value_error("SlerpBone: give a reference or samples, not both");
                 if (py::isinstance<Curve>(reference)) {
                     bone.reference = std::make_shared<OwnedCurveMotion>(reference.cast<Curve>());
                 } else if (!reference.is_none()) {
                     if (!py::isinstance<py::sequence>(reference) || py::len(reference) != 3)
                         throw py::type_error("reference: expected a Curve or (channels, channel_interpolation, mode)");
                     const py::sequence parts = reference.cast<py::sequence>();
                     const RotationMode mode = parse_rotation_mode(parts[2].cast<std::string>());
                     const KeyInterpolation ipo = parse_key_interpolation(parts[1].cast<std::string>());
                     const py::sequence channels = parts[0].cast<py::sequence>();
                     std::vector<FCurveKeys> original;
                     for (std::size_t c = 0; c < channels.size(); ++c) original.push_back(read_fcurve_keys(channels[c], c));
                     auto playback = std::make_shared<PlaybackMotion>(std::move(original), ipo, mode);
                     if (mode.kind == RotationMode::Kind::quaternion) bone.excluded = quaternion_flips(*playback, bone.times);
                     bone.reference = std::move(playback);
                 } else if (!samples.is_none()) {
                     const Batch q = read_rows(samples, 4, "samples", bone.times.size());
                     bone.samples.resize(bone.times.size());
                     for (std::size_t k = 0; k < bone.times.size(); ++k) bone.samples[k] = from_wxyz(q.data() + 4 * k);
                 } else {
                     throw py::value_error("SlerpBone: give a reference or samples");
                 }
                 return bone;
             }),
             py::arg("times"), py::kw_only(), py::arg("reference") = py::none(), py::arg("samples") = py::none(),
             py::arg("cyclic") = false, py::arg("file_unit") = 0.0)
        .def_property_readonly("times", [](const SlerpBone& b) { return vector_array(b.times); })
        .def_readonly("cyclic", &SlerpBone::cyclic)
        .def_property_readonly("proved", [](const SlerpBone& b) { return static_cast<bool>(b.reference); },
                               "whether the keys are proved against a reference at every instant")
        .def("__repr__", [](const SlerpBone& b) {
            return "<SlerpBone " + std::to_string(b.times.size()) + " times, " +
                   (b.reference ? "proved against a reference" : "held at samples") + (b.cyclic ? ", cyclic>" : ">");
        });

    m.def(
        "play_slerp_keys",
        [](py::handle key_times, py::handle keys, py::handle at, bool cyclic) {
            const std::vector<double> kt = read_times(key_times);
            const Batch q = read_rows(keys, 4, "keys", kt.size());
            std::vector<Quat> qs(kt.size());
            for (std::size_t k = 0; k < kt.size(); ++k) qs[k] = from_wxyz(q.data() + 4 * k);
            const std::vector<double> t = read_times(at);
            std::vector<Quat> out;
            {
                py::gil_scoped_release release;
                out = play_slerp_keys(kt, qs, t, cyclic);
            }
            DArray a({static_cast<py::ssize_t>(out.size()), py::ssize_t{4}});
            for (std::size_t k = 0; k < out.size(); ++k) to_wxyz(out[k], a.mutable_data() + 4 * k);
            return a;
        },
        py::arg("key_times"), py::arg("keys"), py::arg("at"), py::kw_only(), py::arg("cyclic") = false,
        R"doc((N, 4): what a glTF LINEAR rotation sampler with keys (K, 4) (w, x, y, z) at key_times (K,)
plays at each of `at`: the keys rounded to float32 (as a file stores them), glTF's slerp between the
two around t, the first key before them and the last after; cyclic: the keys are one period and
repeat.)doc");

    m.def(
        "gltf_slerp",
        [](py::handle a, py::handle b, double t) {
            const Batch qa = as_batch(a, {4}, "a"), qb = as_batch(b, {4}, "b");
            if (qa.count != 1 || qb.count != 1) throw py::value_error("a, b: expected one quaternion each");
            const Quat r = gltf_slerp(from_wxyz(qa.data()), from_wxyz(qb.data()), t);
            DArray out(4);
            to_wxyz(r, out.mutable_data());
            return out;
        },
        py::arg("a"), py::arg("b"), py::arg("t"),
        R"doc(glTF 2.0's slerp (Appendix C) between rotations a and b (w, x, y, z; normalized first) at t:
the shortest way round, whatever their signs. Returns a unit (4,) quaternion.)doc");
}

}  // namespace quatcurve::bindings
