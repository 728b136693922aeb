// Rotation channels and sampling policies (see channels.hpp for what each function promises).
#include "quatcurve/channels.hpp"

#include <algorithm>
#include <cmath>

#include "numbers.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/metrics.hpp"

namespace quatcurve {

namespace {

using numbers::kTwoPi;

// Below this |sin(angle/2)| an axis-angle axis is undefined (the rotation is the identity, ±).
constexpr double kUndefinedAxis = 1e-7;
// Most frames a sampling policy returns (800 MB of doubles): beyond it the caller asked for nonsense.
constexpr double kMaxFrames = 1e8;

std::size_t frame_count(double span, const char* what) {
    if (!(span < kMaxFrames))
        throw InvalidArgument(std::string(what) + ": more than 100000000 frames");
    return static_cast<std::size_t>(span) + 1;
}

std::string row_name(const char* name, std::size_t row) { return std::string(name) + "[" + std::to_string(row) + "]"; }

// Refuses the first zero-length or non-finite row of q, naming it ("quats[12]"). A row whose squared
// norm is plainly in range (which also means finite) passes without building its name or the full
// check's strings: a bake converts every sample of every target through here.
void check_nonzero_rows(const std::vector<Quat>& q, const char* name) {
    for (std::size_t s = 0; s < q.size(); ++s) {
        const double n2 = glm::dot(q[s], q[s]);
        if (n2 > 1e-200 && n2 < 1e300) continue;
        check_nonzero(q[s], row_name(name, s));
    }
}

Vec3 read_vec3(const double* p) { return Vec3(p[0], p[1], p[2]); }

void check_reference(const double* reference, std::size_t rows, std::size_t channels) {
    for (std::size_t k = 0; k < rows * channels; ++k)
        check_finite(reference[k], row_name("reference", k / channels));
}

std::vector<double> euler_channels(const std::vector<Quat>& q, EulerOrder order, const double* reference,
                                   std::size_t reference_rows, EulerBranch branch) {
    const std::size_t n = q.size();
    std::vector<Vec3> angles(n);
    auto ref = [&](std::size_t s) { return read_vec3(reference + 3 * (reference_rows == 1 ? 0 : s)); };
    if (branch == EulerBranch::blender) {
        for (std::size_t s = 0; s < n; ++s) {
            if (reference_rows == n && n > 1) angles[s] = blender_quat_to_euler(q[s], order, ref(s));
            else if (s > 0) angles[s] = blender_quat_to_euler(q[s], order, angles[s - 1]);
            else if (reference_rows) angles[s] = blender_quat_to_euler(q[s], order, ref(0));
            else angles[s] = blender_quat_to_euler(q[s], order);
        }
    } else {
        for (std::size_t s = 0; s < n; ++s)
            angles[s] = reference_rows ? quat_to_euler_compat(q[s], order, ref(s)) : quat_to_euler(q[s], order);
        euler_filter_from_anchor(angles.data(), n, order);
    }
    std::vector<double> out(3 * n);
    for (std::size_t s = 0; s < n; ++s)
        for (int c = 0; c < 3; ++c) out[3 * s + c] = angles[s][c];
    return out;
}

std::vector<double> axis_angle_channels(std::vector<Quat> q, const double* reference) {
    const std::size_t n = q.size();
    hemisphere_continuous(q.data(), n);
    std::vector<Vec3> axis(n);
    std::vector<double> angle(n);
    for (std::size_t s = 0; s < n; ++s) quat_to_axis_angle(q[s], axis[s], angle[s]);
    // Undefined axes take the nearest defined one before them (or, before the first, after them).
    std::ptrdiff_t last = -1;
    for (std::size_t s = 0; s < n; ++s) {
        if (std::fabs(std::sin(0.5 * angle[s])) > kUndefinedAxis) last = static_cast<std::ptrdiff_t>(s);
        else if (last >= 0) axis[s] = axis[static_cast<std::size_t>(last)];
    }
    const auto first = std::find_if(angle.begin(), angle.end(),
                                    [](double a) { return std::fabs(std::sin(0.5 * a)) > kUndefinedAxis; });
    if (first != angle.end())
        std::fill(axis.begin(), axis.begin() + (first - angle.begin()), axis[static_cast<std::size_t>(first - angle.begin())]);
    // (axis, angle) ≡ (−axis, −angle): each axis on its predecessor's side.
    double sign = 1.0;
    std::vector<double> out(4 * n);
    double previous = 0.0;
    for (std::size_t s = 0; s < n; ++s) {
        if (s == 0) {
            if (reference != nullptr && glm::dot(axis[0], read_vec3(reference + 1)) < 0.0) sign = -1.0;
        } else if (glm::dot(axis[s], axis[s - 1]) < 0.0) {
            sign = -sign;
        }
        // Unwrapped: the angle moves by the step nearest the previous one (mod 2π, as numpy.unwrap).
        const double a = sign * angle[s];
        const double start = s > 0 ? previous : (reference != nullptr ? reference[0] : a);
        previous = start + std::remainder(a - start, kTwoPi);
        out[4 * s] = previous;
        for (int c = 0; c < 3; ++c) out[4 * s + 1 + c] = sign * axis[s][c];
    }
    return out;
}

}  // namespace

Curve curve_from_channels(const std::vector<double>& times, const std::vector<double>& values,
                          const RotationMode& mode, Method method, const CurveOptions& options) {
    const std::size_t n = times.size();
    if (values.size() != n * channel_count(mode))
        throw InvalidArgument("values: expected " + std::to_string(n) + " rows of " +
                              std::to_string(channel_count(mode)) + " channel values, got " +
                              std::to_string(values.size()) + " values");
    switch (mode.kind) {
        case RotationMode::Kind::euler:
            return Curve::from_euler(times.data(), values.data(), n, mode.order, method, options);
        case RotationMode::Kind::axis_angle:
            return Curve::from_axis_angle(times, values, method, options);
        case RotationMode::Kind::quaternion:
            break;
    }
    return Curve(times.data(), values.data(), n, method, options);
}

std::vector<double> axis_angle_span_channels(const std::vector<Quat>& q, const double* start, const double* end,
                                             std::size_t* split_out) {
    const std::size_t n = q.size();
    if (split_out != nullptr) *split_out = n;
    check_reference(start, 1, 4);
    check_reference(end, 1, 4);
    check_nonzero_rows(q, "quats");
    std::vector<double> fwd = axis_angle_channels(q, start);
    if (n < 2) return fwd;
    const double* last = &fwd[4 * (n - 1)];
    const bool arrives = std::fabs(last[0] - end[0]) < numbers::kPi &&
                         last[1] * end[1] + last[2] * end[2] + last[3] * end[3] > 0.0;
    if (arrives) return fwd;
    // Lifted backwards from `end`, and the samples from `split` on taken from that lift: the split
    // whose one jump (sample split-1 on the forward lift to split on the backward one, the channels
    // interpolated between them) leaves the samples' own arc least. Near the identity that is the
    // pair on either side of the path's closest approach: there the axis keeps its direction and
    // the angle passes the multiple of 2π, where the two lifts meet; a pair on one side would flip
    // the axis through zero instead. Among equal costs the interior split nearest the identity.
    std::vector<Quat> rev(q.rbegin(), q.rend());
    const std::vector<double> bwd = axis_angle_channels(rev, end);
    auto channel_rotation = [](const double* v) {
        const Vec3 axis(v[1], v[2], v[3]);
        return glm::dot(axis, axis) > 0.0 ? axis_angle_to_quat(axis, v[0]) : Quat(1.0, 0.0, 0.0, 0.0);
    };
    auto jump_cost = [&](std::size_t s) {
        const double* a = &fwd[4 * (s - 1)];
        const double* b = &bwd[4 * (n - 1 - s)];
        double worst = 0.0;
        for (double u : {0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875}) {
            double v[4];
            for (int c = 0; c < 4; ++c) v[c] = a[c] + u * (b[c] - a[c]);
            // The samples' arc, by nlerp (neighbouring samples: within a hair of slerp).
            const Quat qa = q[s - 1], qb = glm::dot(q[s - 1], q[s]) < 0.0 ? -q[s] : q[s];
            const Quat m = (1.0 - u) * qa + u * qb;
            worst = std::max(worst, angle_between(channel_rotation(v), m / std::sqrt(glm::dot(m, m))));
        }
        return worst;
    };
    std::size_t split = n - 1;
    double best = HUGE_VAL, nearest = 2.0;
    for (std::size_t s = 1; s < n; ++s) {
        const double cost = jump_cost(s), d = std::fabs(std::sin(0.5 * fwd[4 * s]));
        if (cost < best - 1e-12 || (cost <= best + 1e-12 && s + 1 < n && d < nearest)) best = cost, nearest = d, split = s;
    }
    for (std::size_t s = split; s < n; ++s)
        for (int c = 0; c < 4; ++c) fwd[4 * s + c] = bwd[4 * (n - 1 - s) + c];
    if (split_out != nullptr) *split_out = split;
    return fwd;
}

RotationMode parse_rotation_mode(const std::string& name) {
    RotationMode mode;
    if (name == "QUATERNION") return mode;
    if (name == "AXIS_ANGLE") {
        mode.kind = RotationMode::Kind::axis_angle;
        return mode;
    }
    try {
        mode.order = parse_euler_order(name);
    } catch (const InvalidArgument&) {
        throw InvalidArgument("mode: unknown rotation mode '" + name +
                              "' (expected QUATERNION, XYZ, XZY, YXZ, YZX, ZXY, ZYX or AXIS_ANGLE)");
    }
    mode.kind = RotationMode::Kind::euler;
    return mode;
}

std::size_t channel_count(const RotationMode& mode) { return mode.kind == RotationMode::Kind::euler ? 3 : 4; }

Quat channels_to_quat(const double* v, const RotationMode& mode, std::size_t row) {
    const std::string name = row_name("values", row);
    switch (mode.kind) {
        case RotationMode::Kind::euler: {
            const Vec3 angles = read_vec3(v);
            check_finite(angles, name);
            return euler_to_quat(angles, mode.order);
        }
        case RotationMode::Kind::axis_angle: {
            const Vec3 axis = read_vec3(v + 1);
            check_finite(v[0], name);
            check_nonzero(axis, name + " axis");
            return axis_angle_to_quat(axis, v[0]);
        }
        case RotationMode::Kind::quaternion:
            break;
    }
    return normalized_rotation(from_wxyz(v), name);
}

void hemisphere_continuous(Quat* q, std::size_t n, const Quat* reference) {
    for (std::size_t s = 0; s < n; ++s) {
        const Quat* before = s > 0 ? &q[s - 1] : reference;
        if (before != nullptr && glm::dot(q[s], *before) < 0.0) q[s] = -q[s];
    }
}

std::vector<double> quats_to_channels(const std::vector<Quat>& q, const RotationMode& mode, const double* reference,
                                      std::size_t reference_rows, EulerBranch branch) {
    const std::size_t n = q.size(), channels = channel_count(mode);
    if (reference == nullptr) reference_rows = 0;
    if (reference_rows > 1 && (mode.kind != RotationMode::Kind::euler || reference_rows != n))
        throw InvalidArgument("reference: expected one row" +
                              std::string(mode.kind == RotationMode::Kind::euler ? " or one per sample" : "") +
                              ", got " + std::to_string(reference_rows));
    check_reference(reference, reference_rows, channels);
    check_nonzero_rows(q, "quats");
    switch (mode.kind) {
        case RotationMode::Kind::euler:
            return euler_channels(q, mode.order, reference, reference_rows, branch);
        case RotationMode::Kind::axis_angle:
            return axis_angle_channels(q, reference_rows ? reference : nullptr);
        case RotationMode::Kind::quaternion:
            break;
    }
    std::vector<Quat> out_q = q;
    const Quat ref = reference_rows ? from_wxyz(reference) : Quat();
    hemisphere_continuous(out_q.data(), n, reference_rows ? &ref : nullptr);
    std::vector<double> out(4 * n);
    for (std::size_t s = 0; s < n; ++s) to_wxyz(out_q[s], out.data() + 4 * s);
    return out;
}

bool sample_channel_keys(const Curve& curve, const double* frames, std::size_t n, const RotationMode& mode,
                         const double* reference, std::size_t reference_rows, float* out) {
    const std::size_t channels = channel_count(mode);
    bool finite = true;
    // Sample k's channel values v as key k of each channel's row of (frame, value) pairs.
    auto put = [&](std::size_t k, const double* v) {
        const float frame = static_cast<float>(frames[k]);
        for (std::size_t c = 0; c < channels; ++c) {
            float* key = out + 2 * (n * c + k);
            key[0] = frame;
            key[1] = static_cast<float>(v[c]);
            finite = finite && std::isfinite(key[1]);
        }
    };
    if (mode.kind != RotationMode::Kind::quaternion) {
        std::vector<double> wxyz(4 * n);
        curve.sample(frames, n, wxyz.data());
        std::vector<Quat> q(n);
        for (std::size_t k = 0; k < n; ++k) q[k] = from_wxyz(&wxyz[4 * k]);
        const std::vector<double> v = quats_to_channels(q, mode, reference, reference_rows);
        for (std::size_t k = 0; k < n; ++k) put(k, &v[channels * k]);
        return finite;
    }
    if (reference == nullptr) reference_rows = 0;
    if (reference_rows > 1)
        throw InvalidArgument("reference: expected one row, got " + std::to_string(reference_rows));
    check_reference(reference, reference_rows, channels);
    // As hemisphere_continuous: each sample on the side of the one before (the first: of the reference).
    constexpr std::size_t kBlock = 256;
    double wxyz[4 * kBlock];
    Quat before = reference_rows ? from_wxyz(reference) : Quat();
    bool has_before = reference_rows > 0;
    for (std::size_t begin = 0; begin < n; begin += kBlock) {
        const std::size_t m = std::min(kBlock, n - begin);
        curve.sample(frames + begin, m, wxyz);
        for (std::size_t i = 0; i < m; ++i) {
            Quat q = from_wxyz(wxyz + 4 * i);
            const double n2 = glm::dot(q, q);  // as check_nonzero_rows
            if (!(n2 > 1e-200 && n2 < 1e300)) check_nonzero(q, row_name("quats", begin + i));
            if (has_before && glm::dot(q, before) < 0.0) q = -q;
            before = q;
            has_before = true;
            double v[4];
            to_wxyz(q, v);
            put(begin + i, v);
        }
    }
    return finite;
}

// ---- sampling policies --------------------------------------------------------------------------------

std::vector<double> step_frames(double start, double end, double step) {
    check_finite(start, "frame_start");
    check_finite(end, "frame_end");
    if (!(step >= 1.0) || !std::isfinite(step)) throw InvalidArgument("step: must be at least 1 frame");
    if (end < start) throw InvalidArgument("frame range: frame_end is before frame_start");
    const std::size_t count = frame_count(std::floor((end - start) / step + 1e-9), "frame range");
    std::vector<double> frames(count);
    for (std::size_t m = 0; m < count; ++m) frames[m] = start + step * static_cast<double>(m);
    if (frames.back() < end - 1e-6) frames.push_back(end);
    return frames;
}

std::vector<double> sample_frames(const std::vector<double>& key_frames, int per_frame) {
    check_increasing(key_frames, "key_frames");
    if (per_frame < 1) throw InvalidArgument("per_frame: must be at least 1");
    if (key_frames.empty()) return {};
    const double first = key_frames.front(), last = key_frames.back();
    const std::size_t count = frame_count(std::floor((last - first) * per_frame + 1e-9), "key_frames");
    // The keys and the grid merged (both increasing). A grid point gives way to a key within 1e-4
    // frames of it, and to any sample on its float32 frame (Blender's frames: beyond frame 2048 half
    // a float32 step passes 1e-4 frame).
    std::vector<double> out;
    out.reserve(key_frames.size() + count);
    std::size_t k = 0;
    bool last_is_key = false;
    const auto near_key = [](double key, double t) { return std::fabs(key - t) < 1e-4 || float(key) == float(t); };
    for (std::size_t m = 0; m < count; ++m) {
        const double t = first + static_cast<double>(m) / per_frame;
        while (k < key_frames.size() && key_frames[k] <= t) {
            out.push_back(key_frames[k++]);
            last_is_key = true;
        }
        if (!out.empty() && (last_is_key ? near_key(out.back(), t) : float(out.back()) == float(t))) continue;
        if (k < key_frames.size() && near_key(key_frames[k], t)) continue;
        out.push_back(t);
        last_is_key = false;
    }
    out.insert(out.end(), key_frames.begin() + static_cast<std::ptrdiff_t>(k), key_frames.end());
    return out;
}

std::vector<double> whole_frame_samples(const std::vector<double>& key_frames) {
    check_increasing(key_frames, "key_frames");
    if (key_frames.empty()) return {};
    const double first = std::ceil(key_frames.front()), last = std::floor(key_frames.back());
    const std::size_t count = last >= first ? frame_count(last - first, "key_frames") : 0;
    // Both lists are sorted already: one linear merge (a dense curve's keys are its whole frames).
    std::vector<double> whole(count);
    for (std::size_t m = 0; m < count; ++m) whole[m] = first + static_cast<double>(m);
    std::vector<double> out(key_frames.size() + count);
    out.erase(std::merge(key_frames.begin(), key_frames.end(), whole.begin(), whole.end(), out.begin()),
              out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

void segment_handles(const double* frames, const double* values, std::size_t n, double* left, double* right) {
    if (n == 0) return;
    if (n == 1) {
        left[0] = frames[0] - 1.0, left[1] = values[0];
        right[0] = frames[0] + 1.0, right[1] = values[0];
        return;
    }
    // Segment g runs from key g to key g + 1; key s has segment s − 1 on its left and s on its right
    // (the first key mirrors segment 0 to its left, the last key segment n − 2 to its right).
    for (std::size_t s = 0; s < n; ++s) {
        const std::size_t in = s > 0 ? s - 1 : 0, out = s + 1 < n ? s : n - 2;
        left[2 * s] = frames[s] - (frames[in + 1] - frames[in]) / 3.0;
        left[2 * s + 1] = values[s] - (values[in + 1] - values[in]) / 3.0;
        right[2 * s] = frames[s] + (frames[out + 1] - frames[out]) / 3.0;
        right[2 * s + 1] = values[s] + (values[out + 1] - values[out]) / 3.0;
        for (int c = 0; c < 2; ++c)
            if (!std::isfinite(left[2 * s + c]) || !std::isfinite(right[2 * s + c]))
                throw InvalidArgument(row_name("values", s) + ": its handles overflow double precision");
    }
}

}  // namespace quatcurve
