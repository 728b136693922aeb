// A bound at every instant (see bound.hpp for what is proved and how).
#include "quatcurve/bound.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <string>

#include "quatcurve/errors.hpp"
#include "quatcurve/quat.hpp"

namespace quatcurve {

namespace {

// std::fmax and std::fmin (the argument that is not NaN, if either) inline: the library calls cost
// a few percent of a proof, which takes millions of them.
inline double max2(double a, double b) { return (b > a || a != a) ? b : a; }
inline double min2(double a, double b) { return (b < a || a != a) ? b : a; }

// Blender's float32 arithmetic beside the exact model the bound reasons about (reduce.hpp's margin).
constexpr double kArithmeticSlack = 2e-6;
constexpr double kPi = 3.141592653589793238462643383279502884;
constexpr double kTwoPi = 2.0 * kPi;
// Blender's binary search takes a frame within this of a key as the key (blender_eval.hpp); the
// snap is bounded over twice that around each key.
constexpr double kKeySnap = 1e-4;

double hypot3(double a, double b, double c) { return std::sqrt(a * a + b * b + c * c); }

// The extremes of a quadratic Bezier (control values p0, p1, p2) on [u0, u1] ⊂ [0, 1] are within
// the control values of its restriction there: its blossom at (u0, u0), (u0, u1), (u1, u1).
void blossom(const double p[3], double u0, double u1, double out[3]) {
    auto b = [&](double s, double t) {
        return (1 - s) * (1 - t) * p[0] + ((1 - s) * t + s * (1 - t)) * p[1] + s * t * p[2];
    };
    out[0] = b(u0, u0);
    out[1] = b(u0, u1);
    out[2] = b(u1, u1);
}

}  // namespace

std::vector<double> Motion::breaks_within(double t0, double t1) const {
    std::vector<double> out;
    for (double t : breaks())
        if (t >= t0 && t <= t1) out.push_back(t);
    return out;
}

Quat CurveMotion::at(double t) const {
    double q[4];
    curve_.sample(&t, 1, q);
    return from_wxyz(q);
}

void CurveMotion::at_many(const double* t, std::size_t n, Quat* out) const {
    // Curve::sample gives a time the same bits alone or in a batch (curve_simd.hpp).
    std::vector<double> q(4 * n);
    curve_.sample(t, n, q.data());
    for (std::size_t i = 0; i < n; ++i) out[i] = from_wxyz(&q[4 * i]);
}

PlaybackMotion::PlaybackMotion(std::vector<FCurveKeys> channels, KeyInterpolation interpolation,
                               const RotationMode& mode)
    : channels_(std::move(channels)), interpolation_(interpolation), mode_(mode) {
    if (channels_.size() != channel_count(mode_))
        throw InvalidArgument("channels: " + std::to_string(channels_.size()) + " F-curves for a rotation of " +
                              std::to_string(channel_count(mode_)) + " channels");
    for (const FCurveKeys& ch : channels_) check_fcurve_keys(ch, interpolation_);
    shared_frames_ = channels_.size() > 1;
    for (std::size_t c = 1; c < channels_.size() && shared_frames_; ++c) {
        const std::vector<double>& a = channels_[0].frames;
        const std::vector<double>& b = channels_[c].frames;
        shared_frames_ = a.size() == b.size();
        for (std::size_t k = 0; k < a.size() && shared_frames_; ++k) shared_frames_ = a[k] == b[k];
    }
}

void PlaybackMotion::values(double t, double* out) const {
    // The proof asks for each interval end several times (the angle there, then the bounds of the
    // intervals on either side): the last few frames are kept.
    const float frame = static_cast<float>(t);
    const std::size_t C = channels_.size();
    for (const Cached& c : cache_)
        if (c.frame == frame && c.valid) {
            std::copy(c.values, c.values + C, out);
            return;
        }
    if (shared_frames_) {
        const FCurveKeys* channels[4];
        for (std::size_t c = 0; c < C; ++c) channels[c] = &channels_[c];
        blender_evaluate_shared(channels, static_cast<int>(C), interpolation_, frame, out);
    } else {
        for (std::size_t c = 0; c < C; ++c) out[c] = blender_evaluate(channels_[c], interpolation_, frame);
    }
    Cached& slot = cache_[next_++ % kCache];
    slot.frame = frame;
    slot.valid = true;
    std::copy(out, out + C, slot.values);
}

Quat PlaybackMotion::at(double t) const {
    double v[4];
    values(t, v);
    switch (mode_.kind) {
        case RotationMode::Kind::quaternion: {
            const Quat q = from_wxyz(v);
            const double n = std::sqrt(glm::dot(q, q));
            return n > 0.0 ? q / n : Quat(0.0, 1.0, 0.0, 0.0);  // Blender's normalize_qt of zero
        }
        case RotationMode::Kind::axis_angle:
            if (v[1] == 0.0 && v[2] == 0.0 && v[3] == 0.0) return Quat(1.0, 0.0, 0.0, 0.0);
            return channels_to_quat(v, mode_);
        case RotationMode::Kind::euler: break;
    }
    return channels_to_quat(v, mode_);
}

namespace {

// The control points Blender evaluates for segment j of a channel (BEZIER; after correct_bezpart:
// a handle reaching farther than the segment is scaled back to it). False: Blender's flat-segment
// shortcut (the first value throughout).
bool segment_controls(const FCurveKeys& ch, std::size_t j, double x[4], double y[4]) {
    const double f0 = ch.frames[j], f1 = ch.frames[j + 1];
    x[0] = f0;
    x[1] = float(ch.handle_right[2 * j]);
    x[2] = float(ch.handle_left[2 * j + 2]);
    x[3] = f1;
    y[0] = float(ch.values[j]);
    y[1] = float(ch.handle_right[2 * j + 1]);
    y[2] = float(ch.handle_left[2 * j + 3]);
    y[3] = float(ch.values[j + 1]);
    if (std::fabs(y[0] - y[1]) < FLT_EPSILON && std::fabs(y[1] - y[2]) < FLT_EPSILON &&
        std::fabs(y[2] - y[3]) < FLT_EPSILON)
        return false;
    const double len = f1 - f0, len1 = std::fabs(x[0] - x[1]), len2 = std::fabs(x[3] - x[2]);
    if (len1 > len) {
        const double fac = len / len1;
        x[1] = x[0] - fac * (x[0] - x[1]);
        y[1] = y[0] - fac * (y[0] - y[1]);
    }
    if (len2 > len) {
        const double fac = len / len2;
        x[2] = x[3] - fac * (x[3] - x[2]);
        y[2] = y[3] - fac * (y[3] - y[2]);
    }
    return true;
}

// Bounds of |dy/dt| and |d²y/dt²| of the Bezier (x(u), y(u)) over the frames [a, b] of it: the
// hodographs' control values over the curve parameters of [a, b] (the whole segment when Blender's
// root finder finds none); y_t = y_u/x_u, y_tt = (y_uu·x_u − y_u·x_uu)/x_u³.
// max |p0 + (p1 − p0)·u| on [u0, u1]
double linear_max(double p0, double p1, double u0, double u1) {
    return max2(std::fabs(p0 + (p1 - p0) * u0), std::fabs(p0 + (p1 - p0) * u1));
}

// What bezier_bounds takes from the frames of a Bezier segment's controls over [a, b]: the curve
// parameters' range, the frame hodograph's control values there and |x''|'s bound. The same for
// every channel whose segment has these frames (channels keyed together).
struct FrameBounds {
    double u0, u1, xmin, xmax, xx;
};

// parameter(frame): Blender's curve parameter at a float32 frame (blender_bezier_parameter of x).
template <class Parameter>
FrameBounds frame_bounds(const double x[4], double a, double b, Parameter parameter) {
    double u0, u1;
    const double len = x[3] - x[0];
    if (std::fabs(x[1] - (x[0] + len / 3.0)) <= 1e-5 * len && std::fabs(x[2] - (x[0] + 2.0 * len / 3.0)) <= 1e-5 * len) {
        // Handles at thirds (the fit's and the reducer's, up to float32): x(u) is within 1e-5·len of
        // x0 + u·len with slope within 3e-5 of len, so the parameters are within 1e-4 of the linear ones.
        u0 = (a - x[0]) / len - 1e-4;
        u1 = (b - x[0]) / len + 1e-4;
    } else {
        u0 = parameter(float(a));
        u1 = parameter(float(b));
    }
    if (u0 < -1e-3 || u1 < -1e-3 || u0 > u1) {
        u0 = 0.0;
        u1 = 1.0;
    }
    u0 = std::clamp(u0, 0.0, 1.0);
    u1 = std::clamp(u1, 0.0, 1.0);
    const double dx[3] = {3 * (x[1] - x[0]), 3 * (x[2] - x[1]), 3 * (x[3] - x[2])};
    double bx[3];
    blossom(dx, u0, u1, bx);
    FrameBounds f;
    f.u0 = u0;
    f.u1 = u1;
    f.xmin = min2(bx[0], min2(bx[1], bx[2]));
    f.xmax = max2(bx[0], max2(bx[1], bx[2]));
    f.xx = linear_max(6 * (x[2] - 2 * x[1] + x[0]), 6 * (x[3] - 2 * x[2] + x[1]), u0, u1);
    return f;
}

void value_bounds(const FrameBounds& f, const double y[4], double& rate, double& curvature) {
    const double u0 = f.u0, u1 = f.u1;
    const double dy[3] = {3 * (y[1] - y[0]), 3 * (y[2] - y[1]), 3 * (y[3] - y[2])};
    double by[3];
    blossom(dy, u0, u1, by);
    const double ymax = max2(std::fabs(by[0]), max2(std::fabs(by[1]), std::fabs(by[2])));
    const double yy = linear_max(6 * (y[2] - 2 * y[1] + y[0]), 6 * (y[3] - 2 * y[2] + y[1]), u0, u1);
    if (!(f.xmin > 0.0)) {
        rate = curvature = ymax > 0.0 ? HUGE_VAL : 0.0;
        return;
    }
    rate = ymax / f.xmin;
    curvature = (yy * f.xmax + ymax * f.xx) / (f.xmin * f.xmin * f.xmin);
}

FrameBounds frame_bounds(const double x[4], double a, double b) {
    return frame_bounds(x, a, b, [x](float frame) {
        return blender_bezier_parameter(frame, float(x[0]), float(x[1]), float(x[2]), float(x[3]));
    });
}

void bezier_bounds(const double x[4], const double y[4], double a, double b, double& rate, double& curvature) {
    value_bounds(frame_bounds(x, a, b), y, rate, curvature);
}

// std::upper_bound (Upper) or std::lower_bound of x in f, trying `hint` (the last result) and the
// index after it first: the proof asks for the intervals of a sweep in time order.
template <bool Upper>
std::size_t hinted_bound(const std::vector<double>& f, double x, std::size_t& hint) {
    const std::size_t n = f.size();
    auto before = [x](double v) { return Upper ? v <= x : v < x; };  // v lies before the bound
    for (std::size_t h = std::min(hint, n), last = std::min(hint + 1, n); h <= last; ++h)
        if ((h == 0 || before(f[h - 1])) && (h == n || !before(f[h]))) return hint = h;
    const auto it = Upper ? std::upper_bound(f.begin(), f.end(), x) : std::lower_bound(f.begin(), f.end(), x);
    return hint = static_cast<std::size_t>(it - f.begin());
}

// The segment of `ch` holding [lo, hi] whole (no key strictly inside), or −1.
long segment_of(const FCurveKeys& ch, double lo, double hi) {
    const std::size_t n = ch.frames.size();
    if (n < 2 || lo < ch.frames.front() || hi > ch.frames.back()) return -1;
    std::size_t j = static_cast<std::size_t>(std::upper_bound(ch.frames.begin(), ch.frames.end(), lo) - ch.frames.begin());
    j = j == 0 ? 0 : std::min(j - 1, n - 2);
    return hi <= ch.frames[j + 1] ? static_cast<long>(j) : -1;
}

}  // namespace

void PlaybackMotion::channel_bounds(std::size_t c, double t0, double t1, double& rate, double& curvature) const {
    const FCurveKeys& ch = channels_.at(c);
    const std::size_t n = ch.frames.size();
    rate = curvature = 0.0;
    if (n < 2) return;
    const double lo = max2(t0, ch.frames.front()), hi = min2(t1, ch.frames.back());
    if (lo > hi) return;  // constant extrapolation
    std::size_t j = hinted_bound<true>(ch.frames, lo, channel_cache_[c].segment);
    j = j == 0 ? 0 : std::min(j - 1, n - 2);
    for (; j + 1 < n && ch.frames[j] <= hi; ++j) {
        const double f0 = ch.frames[j], f1 = ch.frames[j + 1];
        if (interpolation_ == KeyInterpolation::LINEAR) {
            rate = max2(rate, std::fabs(float(ch.values[j + 1]) - float(ch.values[j])) / (f1 - f0));
            continue;
        }
        const ChannelCache& s = segment(c, j);
        if (!s.controls.bezier) continue;
        const double* x = s.controls.x;
        double r, k;
        value_bounds(frame_bounds(x, max2(lo, f0), min2(hi, f1),
                                  [this, c](float frame) { return parameter(c, frame); }),
                     s.controls.y, r, k);
        rate = max2(rate, r);
        curvature = max2(curvature, k);
    }
}

float PlaybackMotion::parameter(std::size_t c, float frame) const {
    // The interval's ends, which the next interval (or the value there) asks for again: the last two
    // kept per channel and segment.
    ChannelCache& cc = channel_cache_[c];
    for (int m = 0; m < cc.known; ++m)
        if (cc.frame[m] == frame) return cc.u[m];
    const double* x = cc.controls.x;
    const float u = blender_bezier_parameter(frame, float(x[0]), float(x[1]), float(x[2]), float(x[3]));
    cc.frame[cc.next] = frame;
    cc.u[cc.next] = u;
    cc.next ^= 1;
    cc.known = std::min(cc.known + 1, 2);
    return u;
}

const PlaybackMotion::ChannelCache& PlaybackMotion::segment(std::size_t c, std::size_t j) const {
    ChannelCache& cc = channel_cache_[c];
    if (cc.j != j) {
        const FCurveKeys& ch = channels_[c];
        cc.j = j;
        cc.known = cc.next = 0;
        cc.controls.bezier = segment_controls(ch, j, cc.controls.x, cc.controls.y);
        // may_be_flat's spread: the four control values as stored (before correct_bezpart).
        const double y[4] = {float(ch.values[j]), float(ch.handle_right[2 * j + 1]), float(ch.handle_left[2 * j + 3]),
                             float(ch.values[j + 1])};
        cc.spread = max2(max2(y[0], y[1]), max2(y[2], y[3])) -
                    min2(min2(y[0], y[1]), min2(y[2], y[3]));
    }
    return cc;
}

// channel_bounds of every channel, for channels with the same key frames: the segments found once,
// and each segment's frame bounds computed once for the channels whose handle frames agree (the same
// numbers channel_bounds computes for each).
void PlaybackMotion::all_channel_bounds(double t0, double t1, double* rate, double* curvature) const {
    const std::size_t C = channels_.size();
    const std::vector<double>& frames = channels_[0].frames;
    const std::size_t n = frames.size();
    std::fill(rate, rate + C, 0.0);
    std::fill(curvature, curvature + C, 0.0);
    if (n < 2) return;
    const double lo = max2(t0, frames.front()), hi = min2(t1, frames.back());
    if (lo > hi) return;  // constant extrapolation
    std::size_t j = hinted_bound<true>(frames, lo, channel_cache_[0].segment);
    j = j == 0 ? 0 : std::min(j - 1, n - 2);
    for (; j + 1 < n && frames[j] <= hi; ++j) {
        const double f0 = frames[j], f1 = frames[j + 1];
        if (interpolation_ == KeyInterpolation::LINEAR) {
            for (std::size_t c = 0; c < C; ++c)
                rate[c] = max2(rate[c], std::fabs(float(channels_[c].values[j + 1]) - float(channels_[c].values[j])) / (f1 - f0));
            continue;
        }
        const double* known = nullptr;  // the frames `f` was computed for
        FrameBounds f{};
        for (std::size_t c = 0; c < C; ++c) {
            const SegmentControls& s = segment(c, j).controls;
            double r, k;
            if (!s.bezier) continue;
            if (known == nullptr || !std::equal(s.x, s.x + 4, known)) {
                f = frame_bounds(s.x, max2(lo, f0), min2(hi, f1),
                                 [this, c](float frame) { return parameter(c, frame); });
                known = s.x;
            }
            value_bounds(f, s.y, r, k);
            rate[c] = max2(rate[c], r);
            curvature[c] = max2(curvature[c], k);
        }
    }
}

bool PlaybackMotion::combined_rate(std::size_t a, std::size_t c, double sign, double t0, double t1,
                                   double& rate) const {
    const FCurveKeys& A = channels_[a];
    const FCurveKeys& B = channels_[c];
    const long ja = segment_of(A, t0, t1), jc = segment_of(B, t0, t1);
    if (ja < 0 || jc < 0) return false;
    const std::size_t i = static_cast<std::size_t>(ja), k = static_cast<std::size_t>(jc);
    if (A.frames[i] != B.frames[k] || A.frames[i + 1] != B.frames[k + 1]) return false;
    if (interpolation_ == KeyInterpolation::LINEAR) {
        const double dy = (float(A.values[i + 1]) - float(A.values[i])) + sign * (float(B.values[k + 1]) - float(B.values[k]));
        rate = std::fabs(dy) / (A.frames[i + 1] - A.frames[i]);
        return true;
    }
    double xa[4], ya[4], xc[4], yc[4];
    const bool fa = segment_controls(A, i, xa, ya), fc = segment_controls(B, k, xc, yc);
    if (!fa) std::fill(ya, ya + 4, ya[0]);  // flat: a constant
    if (!fc) std::fill(yc, yc + 4, yc[0]);
    if ((fa && fc) && !std::equal(xa, xa + 4, xc)) return false;
    const double* x = fa ? xa : xc;
    double y[4], curvature;
    for (int m = 0; m < 4; ++m) y[m] = ya[m] + sign * yc[m];
    bezier_bounds(x, y, t0, t1, rate, curvature);
    return true;
}

namespace {

// max |sin(x/2)| for x in [lo, hi]: 1 where the interval holds an odd multiple of π (a peak), else
// the larger end (|sin(x/2)| rises from each multiple of 2π to the next peak).
double max_abs_half_sine(double lo, double hi) {
    if (!(hi - lo < kTwoPi)) return 1.0;
    const double peak = kPi + kTwoPi * std::ceil((lo - kPi) / kTwoPi);  // the first odd multiple ≥ lo
    if (peak <= hi) return 1.0;
    return max2(std::fabs(std::sin(0.5 * lo)), std::fabs(std::sin(0.5 * hi)));
}

}  // namespace

namespace {

// Blender's is_eqt(frame, key, 1e-4) in float32 (blender_eval.cpp): the frame is taken as the key.
bool snaps(float frame, float key) {
    return frame > key ? (frame - key) <= float(kKeySnap) : (key - frame) <= float(kKeySnap);
}

// The float32 frames where the snap zone of `key` begins and ends, and the frames just outside it:
// from float(key ∓ 1e-4), a few float32 steps to the exact edge of Blender's comparison. With `zone`:
// its first and last frames alone, there (nothing added to `out`).
void snap_edges(float key, std::vector<double>& out, double* zone = nullptr) {
    auto edge = [&](float start, float outward) {
        float f = start;
        for (int i = 0; i < 64 && !snaps(f, key); ++i) f = std::nextafter(f, key);  // inside
        for (int i = 0; i < 64; ++i) {
            const float next = std::nextafter(f, outward);
            if (!snaps(next, key)) break;
            f = next;
        }
        return f;
    };
    const float lo = edge(static_cast<float>(double(key) - kKeySnap), -HUGE_VALF);
    const float hi = edge(static_cast<float>(double(key) + kKeySnap), HUGE_VALF);
    if (zone) {
        zone[0] = lo;
        zone[1] = hi;
        return;
    }
    out.push_back(std::nextafter(lo, -HUGE_VALF));
    out.push_back(lo);
    out.push_back(key);
    out.push_back(hi);
    out.push_back(std::nextafter(hi, HUGE_VALF));
}

}  // namespace

bool PlaybackMotion::raw_channels(double t, double* a) const {
    if (mode_.kind != RotationMode::Kind::quaternion) return false;
    values(t, a);
    return true;
}

namespace {

// How [t0, t1] (float32 frames) meets the snap zone of `key` (the frames Blender shows as the key):
// 0 apart, 1 inside it, 2 partly. The zone reaches 1e-4 from the key up to float32 rounding: frames
// clearly nearer or farther are decided at once, the few in between by the zone's exact edges.
int snap_overlap(double key, double t0, double t1) {
    constexpr double kSure = 0.99 * kKeySnap, kBeyond = 1.01 * kKeySnap;
    if (t1 < key - kBeyond || t0 > key + kBeyond) return 0;
    if (t0 >= key - kSure && t1 <= key + kSure) return 1;
    auto unsure = [&](double t) {
        const double d = std::fabs(t - key);
        return d > kSure && d < kBeyond;
    };
    if (!unsure(t0) && !unsure(t1)) return 2;
    std::vector<double> none;
    double zone[2];
    snap_edges(static_cast<float>(key), none, zone);
    if (t1 < zone[0] || t0 > zone[1]) return 0;
    return t0 >= zone[0] && t1 <= zone[1] ? 1 : 2;
}

}  // namespace

// Whether a BEZIER segment of channel c meeting [lo, hi] has its four control values (as Blender reads
// them, float32) within 4 ulps of `magnitude` of each other: the only segments Blender's flat-segment
// shortcut (or segment_controls') may take, each test being three differences below FLT_EPSILON.
bool PlaybackMotion::may_be_flat(std::size_t c, double lo, double hi, double magnitude) const {
    const FCurveKeys& ch = channels_[c];
    const std::size_t n = ch.frames.size();
    if (n < 2 || ch.handle_left.size() != 2 * n || ch.handle_right.size() != 2 * n) return n >= 2;
    std::size_t j = hinted_bound<true>(ch.frames, lo, channel_cache_[c].segment);
    j = j == 0 ? 0 : std::min(j - 1, n - 2);
    const double spread = 4.0 * FLT_EPSILON * magnitude;
    for (; j + 1 < n && ch.frames[j] <= hi; ++j)
        if (segment(c, j).spread < spread) return true;
    return false;
}

bool PlaybackMotion::raw_bounds(double t0, double t1, double* rate, double* curvature, double* step) const {
    if (mode_.kind != RotationMode::Kind::quaternion) return false;
    // A frame in the snap zone of a key shows the key's value: the piece's value at the key, off its
    // value at the frame by at most the rate times the zone's reach (with room for float32). An
    // interval partly in a zone takes that step; a key beyond an end whose zone reaches into the
    // interval widens the interval the rates cover (the piece between the key and the end).
    const double reach = 1.01 * kKeySnap;
    double v0[4], v1[4];
    values(t0, v0);
    values(t1, v1);
    for (std::size_t c = 0; c < 4; ++c) {
        const std::vector<double>& f = channels_[c].frames;
        double lo = t0, hi = t1;
        bool partly = false;
        for (std::size_t k = hinted_bound<false>(f, t0 - reach, channel_cache_[c].snap); k < f.size() && f[k] <= t1 + reach;
             ++k) {
            if (snap_overlap(f[k], t0, t1) != 2) continue;
            partly = true;
            lo = min2(lo, f[k]);
            hi = max2(hi, f[k]);
        }
        channel_bounds(c, lo, hi, rate[c], curvature[c]);
        // A flat segment plays its first value up to the next key, whose value may differ by the
        // flatness threshold (3 × FLT_EPSILON, segment_controls); float32 values: 4 ulps of the
        // largest magnitude around cover it. Only a BEZIER segment whose four control values lie that
        // close may be flat (for Blender or for segment_controls): elsewhere the piece is the cubic.
        const double magnitude = max2(1.0, max2(std::fabs(v0[c]), std::fabs(v1[c])));
        const bool flat = interpolation_ == KeyInterpolation::BEZIER && may_be_flat(c, lo, hi, magnitude);
        step[c] = (partly ? reach * rate[c] : 0.0) + (flat ? 4.0 * FLT_EPSILON * magnitude : 0.0);
    }
    return true;
}

void PlaybackMotion::raw_snap_edges(double t0, double t1, std::vector<double>& out) const {
    if (mode_.kind != RotationMode::Kind::quaternion) return;
    const double reach = 1.01 * kKeySnap;
    for (std::size_t c = 0; c < channels_.size(); ++c) {
        const std::vector<double>& f = channels_[c].frames;
        for (std::size_t k = hinted_bound<false>(f, t0 - reach, channel_cache_[c].snap); k < f.size() && f[k] <= t1 + reach;
             ++k) {
            if (snap_overlap(f[k], t0, t1) != 2) continue;
            ChannelCache& cc = channel_cache_[c];
            if (cc.snap_key != k) {  // the edges of the key asked for last are kept
                std::vector<double> edges;
                snap_edges(static_cast<float>(f[k]), edges);
                std::copy(edges.begin(), edges.end(), cc.snap_edges);  // the five of snap_edges
                cc.snap_key = k;
            }
            for (double e : cc.snap_edges)
                if (e > t0 && e < t1) out.push_back(e);
        }
    }
}

std::vector<double> PlaybackMotion::raw_keys() const {
    if (mode_.kind != RotationMode::Kind::quaternion) return {};
    std::vector<double> out;
    for (const FCurveKeys& ch : channels_) out.insert(out.end(), ch.frames.begin(), ch.frames.end());
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

void PlaybackMotion::bounds(double t0, double t1, double& speed, double& accel) const {
    double r[4] = {0.0, 0.0, 0.0, 0.0}, k[4] = {0.0, 0.0, 0.0, 0.0};
    if (shared_frames_) {
        all_channel_bounds(t0, t1, r, k);
    } else {
        for (std::size_t c = 0; c < channels_.size(); ++c) channel_bounds(c, t0, t1, r[c], k[c]);
    }
    switch (mode_.kind) {
        case RotationMode::Kind::euler: {
            // Each axis' rotation turns at its own angle's rate, whatever frame it acts in; the axes
            // themselves turn at most at the sum.
            const double w = r[0] + r[1] + r[2];
            speed = min2(w, euler_speed(t0, t1, r));
            accel = 0.5 * (k[0] + k[1] + k[2] + w * w) + 0.25 * w * w;
            return;
        }
        case RotationMode::Kind::quaternion: {
            const double d1 = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
            const double d2 = std::sqrt(k[0] * k[0] + k[1] * k[1] + k[2] * k[2] + k[3] * k[3]);
            if (d1 == 0.0 && d2 == 0.0) {
                speed = accel = 0.0;
                return;
            }
            double v0[4], v1[4];
            values(t0, v0);
            values(t1, v1);
            const double n0 = std::sqrt(v0[0] * v0[0] + v0[1] * v0[1] + v0[2] * v0[2] + v0[3] * v0[3]);
            const double n1 = std::sqrt(v1[0] * v1[0] + v1[1] * v1[1] + v1[2] * v1[2] + v1[3] * v1[3]);
            const double low = min2(n0, n1) - d1 * 0.5 * (t1 - t0);
            if (!(low > 0.0)) {
                speed = accel = HUGE_VAL;
                return;
            }
            speed = 2.0 * d1 / low;  // |ω| = 2|q̇|, |q̇| ≤ |a'|/|a|
            accel = 2.0 * d2 / low + 5.0 * d1 * d1 / (low * low);
            return;
        }
        case RotationMode::Kind::axis_angle: {
            const double dv = hypot3(r[1], r[2], r[3]), kv = hypot3(k[1], k[2], k[3]);
            double dn = 0.0, kn = 0.0, S = 1.0;  // bounds of |n'|, |n''| (n = v/|v|) and |sin(θ/2)|
            if (dv > 0.0 || kv > 0.0) {
                double v0[4], v1[4];
                values(t0, v0);
                values(t1, v1);
                const double low = min2(hypot3(v0[1], v0[2], v0[3]), hypot3(v1[1], v1[2], v1[3])) - dv * 0.5 * (t1 - t0);
                if (!(low > 0.0)) {
                    speed = accel = HUGE_VAL;
                    return;
                }
                dn = dv / low;
                kn = 2.0 * kv / low + 5.0 * dv * dv / (low * low);
                // The axis moves the rotation only by sin(θ/2): near θ = 2πm (the rest pose, where
                // every axis is the same rotation) a turning axis hardly moves it. |θ'| ≤ r[0] keeps
                // θ within [min − r[0]·h/2, max + r[0]·h/2] of its ends' values.
                const double spread = 0.5 * r[0] * (t1 - t0);
                S = max_abs_half_sine(min2(v0[0], v1[0]) - spread, max2(v0[0], v1[0]) + spread);
            }
            speed = r[0] + 2.0 * S * dn;  // |ω| = 2|q̇| ≤ |θ'| + 2|sin(θ/2)|·|n'|
            accel = 0.25 * r[0] * r[0] + 0.5 * k[0] + r[0] * dn + S * kn;
            return;
        }
    }
    speed = accel = HUGE_VAL;
}



// Near gimbal lock the first and last angles (a, c) turn about nearly the same axis: with κ = e_a·e_c
// (world axes) = σ·sin b, |ω|² = b'² + a'² + c'² + 2κ·a'c' = b'² + (a' + κc')² + (1 − κ²)·c'², and
// |a' + κc'| ≤ |a' + s·c'| + (1 − |κ|)·|c'| with s = sign κ. The rate of a + s·c is bounded from the
// two channels' shared Bezier segment (the same key and handle frames); otherwise +∞ (the sum of the
// rates applies).
double PlaybackMotion::euler_speed(double t0, double t1, const double* r) const {
    const int i = static_cast<int>(euler_order_name(mode_.order)[0] - 'X');
    const int j = static_cast<int>(euler_order_name(mode_.order)[1] - 'X');
    const int l = static_cast<int>(euler_order_name(mode_.order)[2] - 'X');
    Vec3 ea(0.0), eb(0.0), ec(0.0);
    ea[i] = eb[j] = ec[l] = 1.0;
    const double sigma = glm::dot(glm::cross(eb, ea), ec);  // κ = σ·sin b
    double v0[3], v1[3];
    values(t0, v0);
    values(t1, v1);
    // The middle angle's range on the interval, and so |κ|'s least value and κ's sign.
    const double spread = r[j] * 0.5 * (t1 - t0);
    const double b_lo = min2(v0[j], v1[j]) - spread, b_hi = max2(v0[j], v1[j]) + spread;
    const double s0 = std::sin(b_lo), s1 = std::sin(b_hi);
    if (b_hi - b_lo >= kPi || s0 * s1 <= 0.0) return HUGE_VAL;  // κ may change sign (or b winds round)
    // |sin| is smallest at an end of the range unless the range holds a multiple of π (excluded above).
    const double kappa_min = min2(std::fabs(s0), std::fabs(s1));
    double combined;
    if (!combined_rate(static_cast<std::size_t>(i), static_cast<std::size_t>(l), sigma * (s0 > 0 ? 1.0 : -1.0), t0, t1,
                       combined))
        return HUGE_VAL;
    const double along = combined + (1.0 - kappa_min) * r[l];
    return std::sqrt(r[j] * r[j] + along * along + (1.0 - kappa_min * kappa_min) * r[l] * r[l]);
}

std::vector<double> PlaybackMotion::breaks() const {
    std::vector<double> out;
    for (const FCurveKeys& ch : channels_) {
        if (ch.frames.size() > 4096 * 64) {  // dense keys: the key frames only
            out.insert(out.end(), ch.frames.begin(), ch.frames.end());
            continue;
        }
        for (double f : ch.frames) snap_edges(float(f), out);
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

double PlaybackMotion::jump_bound(double t0, double t1, double speed) const {
    // Frames are float32: Blender evaluates at float(t), within half an ulp (≤ |t|·2⁻²⁴) of t. (The
    // snap to a key within 1e-4 of it is a step at frames that are breaks: prove_within evaluates
    // both sides of it.)
    const double ulp = max2(std::fabs(t0), std::fabs(t1)) * std::ldexp(1.0, -23) + 1e-30;
    return speed * 2.0 * ulp;
}

PlaybackBound prove_within(const Motion& a, const Motion& b, const std::vector<double>& given, double tolerance,
                           double min_step, std::size_t max_evaluations) {
    if (given.empty()) throw InvalidArgument("times: at least one time");
    for (std::size_t i = 0; i < given.size(); ++i) {
        if (!std::isfinite(given[i])) throw InvalidArgument("times[" + std::to_string(i) + "]: not finite");
        if (i > 0 && given[i] < given[i - 1]) throw InvalidArgument("times[" + std::to_string(i) + "]: not sorted");
    }
    if (!(tolerance >= 0.0) || !std::isfinite(tolerance)) throw InvalidArgument("tolerance: must be finite and >= 0");
    if (!(min_step > 0.0) || !std::isfinite(min_step)) throw InvalidArgument("min_step: must be finite and > 0");
    if (max_evaluations == 0) throw InvalidArgument("max_evaluations: must be at least 1");
    // The evaluated times: the given ones and every break of either motion between them.
    // Frames as Blender's: float32 (an interval between two neighbouring float32 frames has no
    // other frame Blender can evaluate).
    std::vector<double> times;
    times.reserve(given.size());
    for (double t : given) times.push_back(static_cast<float>(t));
    const double first = times.front(), last = times.back();
    // Two float32 playbacks of quaternion channels take the channels bound alone (bound.hpp), which
    // covers the snap to a key as a step: their corners are the key frames, without the snap edges.
    double probe[4];
    const bool raw = a.float32_frames() && b.float32_frames() && a.raw_channels(first, probe) &&
                     b.raw_channels(first, probe);
    for (const Motion* m : {&a, &b})
        for (double t : raw ? m->raw_keys() : m->breaks_within(first, last))
            if (t > first && t < last) times.push_back(t);
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());

    PlaybackBound r;
    struct Point {
        double t, d;
        Quat qa, qb;
    };
    auto evaluate = [&](double t) {
        ++r.evaluations;
        Point p{t, 0.0, a.at(t), b.at(t)};
        p.d = angle_between(p.qa, p.qb);
        if (p.d > r.max_evaluated) r.max_evaluated = p.d;
        return p;
    };
    auto reach = [&](double bound, double t) {
        if (bound > r.bound) {
            r.bound = bound;
            r.worst_time = t;
        }
    };
    // The channels bound (bound.hpp) of two quaternion playbacks on [p0.t, p1.t], or +∞. With the
    // steps (ε_A, ε_B: |a(t) − its piece|): |D(t)| ≤ max |D(ends)| + K·h²/8 + 2(ε_A + λε_B) (the ends
    // and t each off the pieces' D), |a_A(t)| ≥ min |a_A(ends)| − max|a_A'|·h/2 − 2ε_A.
    auto channels_bound = [&](const Point& p0, const Point& p1) {
        double a0[4], a1[4], b0[4], b1[4], ra[4], ka[4], sa_[4], rb[4], kb[4], sb_[4];
        a.raw_channels(p0.t, a0);
        a.raw_channels(p1.t, a1);
        b.raw_channels(p0.t, b0);
        b.raw_channels(p1.t, b1);
        if (!a.raw_bounds(p0.t, p1.t, ra, ka, sa_) || !b.raw_bounds(p0.t, p1.t, rb, kb, sb_)) return HUGE_VAL;
        auto dot = [](const double* u, const double* v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2] + u[3] * v[3]; };
        const double sigma = dot(a0, b0) < 0.0 ? -1.0 : 1.0;
        const double nb0 = dot(b0, b0), nb1 = dot(b1, b1);
        if (!(nb0 > 0.0) || !(nb1 > 0.0)) return HUGE_VAL;
        // λ(t) linear from each end's projection: D at the ends is the perpendicular part alone.
        const double l0 = sigma * dot(a0, b0) / nb0, l1 = sigma * dot(a1, b1) / nb1;
        if (!(l0 > 0.0) || !(l1 > 0.0) || !std::isfinite(l0) || !std::isfinite(l1)) return HUGE_VAL;
        const double h = p1.t - p0.t, lmax = max2(l0, l1), lmin = min2(l0, l1);
        const double slope = std::fabs(l1 - l0) / h;
        double d0 = 0.0, d1 = 0.0, K = 0.0, sa = 0.0, sb = 0.0, ea = 0.0, eb = 0.0;
        for (int c = 0; c < 4; ++c) {
            const double e0 = a0[c] - l0 * sigma * b0[c], e1 = a1[c] - l1 * sigma * b1[c];
            const double k = ka[c] + lmax * kb[c] + 2.0 * slope * rb[c];
            d0 += e0 * e0;
            d1 += e1 * e1;
            K += k * k;
            sa += ra[c] * ra[c];
            sb += rb[c] * rb[c];
            ea += sa_[c] * sa_[c];
            eb += sb_[c] * sb_[c];
        }
        ea = std::sqrt(ea);
        eb = std::sqrt(eb);
        const double D = std::sqrt(max2(d0, d1)) + std::sqrt(K) * h * h / 8.0 + 2.0 * (ea + lmax * eb);
        const double low_a = std::sqrt(min2(dot(a0, a0), dot(a1, a1))) - std::sqrt(sa) * 0.5 * h - 2.0 * ea;
        const double low_b = lmin * (std::sqrt(min2(nb0, nb1)) - std::sqrt(sb) * 0.5 * h - 2.0 * eb);
        const double low = max2(low_a, low_b);
        if (!(D < low)) return HUGE_VAL;  // (NaN bounds included)
        return 2.0 * std::asin(D / low);
    };
    auto interval_bound = [&](const Point& p0, const Point& p1) {
        const double h = p1.t - p0.t;
        const bool neighbours = std::nextafter(static_cast<float>(p0.t), HUGE_VALF) >= static_cast<float>(p1.t);
        // Two float32 playbacks of quaternion channels: the channels bound, which usually suffices
        // alone (the motions' own bounds below then need not be computed).
        if (raw) return neighbours ? max2(p0.d, p1.d) + kArithmeticSlack : channels_bound(p0, p1) + kArithmeticSlack;
        double va, aa, vb, ab;
        a.bounds(p0.t, p1.t, va, aa);
        b.bounds(p0.t, p1.t, vb, ab);
        if (neighbours) {
            // Neighbouring float32 frames: a float32 motion shows one of its two ends in between (a
            // step there, such as the snap to a key, included), the other moves by at most its speed
            // (from either end: d ≤ max(d0, d1) + its speed·h); two float32 motions show the same end
            // (Blender evaluates both at the same frame).
            if (a.float32_frames() && b.float32_frames()) return max2(p0.d, p1.d) + kArithmeticSlack;
            const double moving = (a.float32_frames() ? 0.0 : va) + (b.float32_frames() ? 0.0 : vb);
            return max2(p0.d, p1.d) + moving * h + kArithmeticSlack;
        }
        const double first = max2(0.5 * (p0.d + p1.d + (va + vb) * h), max2(p0.d, p1.d));
        const double sigma = glm::dot(p0.qa, p0.qb) < 0.0 ? -1.0 : 1.0;
        const double c0 = glm::length(glm::dvec4(p0.qa.w - sigma * p0.qb.w, p0.qa.x - sigma * p0.qb.x,
                                                  p0.qa.y - sigma * p0.qb.y, p0.qa.z - sigma * p0.qb.z));
        const double c1 = glm::length(glm::dvec4(p1.qa.w - sigma * p1.qb.w, p1.qa.x - sigma * p1.qb.x,
                                                  p1.qa.y - sigma * p1.qb.y, p1.qa.z - sigma * p1.qb.z));
        const double chord = max2(c0, c1) + (aa + ab) * h * h / 8.0;
        const double second = chord < 2.0 ? 4.0 * std::asin(0.5 * chord) : HUGE_VAL;
        // Two float32 motions are both evaluated at float(t), a frame inside [t0, t1] (its ends are
        // float32 frames): the bounds of the interval cover it with no jump for the rounding.
        const double jumps = a.float32_frames() && b.float32_frames()
                                 ? 0.0
                                 : a.jump_bound(p0.t, p1.t, va) + b.jump_bound(p0.t, p1.t, vb);
        return min2(first, second) + jumps + kArithmeticSlack;
    };
    // b at every time of the list at once (a curve samples four at a time); a, whose last few values
    // bound the intervals (PlaybackMotion's cache), as the sweep reaches each time.
    std::vector<Quat> b_at(times.size());
    b.at_many(times.data(), times.size(), b_at.data());
    auto evaluate_listed = [&](std::size_t i) {
        ++r.evaluations;
        Point p{times[i], 0.0, a.at(times[i]), b_at[i]};
        p.d = angle_between(p.qa, p.qb);
        if (p.d > r.max_evaluated) r.max_evaluated = p.d;
        return p;
    };
    std::vector<std::pair<Point, Point>> stack;
    std::vector<double> edges;  // raw_snap_edges' (kept: most intervals split have none)
    Point prev = evaluate_listed(0);
    reach(prev.d, prev.t);
    if (prev.d > tolerance) r.violations.push_back(prev.t);
    for (std::size_t i = 1; i < times.size(); ++i) {
        const Point next = evaluate_listed(i);
        reach(next.d, next.t);
        if (next.d > tolerance) r.violations.push_back(next.t);
        stack.emplace_back(prev, next);
        prev = next;
        while (!stack.empty()) {
            const auto [p0, p1] = stack.back();
            stack.pop_back();
            if (!(p1.t > p0.t)) continue;
            const double bound = interval_bound(p0, p1);
            const double mid = static_cast<float>(0.5 * (p0.t + p1.t));
            if (bound <= tolerance || p0.d > tolerance || p1.d > tolerance) {
                reach(bound, mid);  // proved, or a violation at an end, known already
                continue;
            }
            if (raw && r.evaluations < max_evaluations) {
                // Two playbacks: an interval partly in a key's snap zone is split at the zone's edges
                // (the step it takes there does not shrink with the interval).
                edges.clear();
                a.raw_snap_edges(p0.t, p1.t, edges);
                b.raw_snap_edges(p0.t, p1.t, edges);
                if (!edges.empty()) {
                    std::sort(edges.begin(), edges.end());
                    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
                    std::vector<Point> points{p0};
                    for (double t : edges) {
                        points.push_back(evaluate(t));
                        reach(points.back().d, t);
                        if (points.back().d > tolerance) r.violations.push_back(t);
                    }
                    points.push_back(p1);
                    for (std::size_t k = points.size() - 1; k > 0; --k) stack.emplace_back(points[k - 1], points[k]);
                    continue;
                }
            }
            if (p1.t - p0.t < min_step || r.evaluations >= max_evaluations || !(mid > p0.t && mid < p1.t)) {
                r.unproven.emplace_back(p0.t, p1.t);
                reach(bound, mid);
                continue;
            }
            const Point pm = evaluate(mid);
            if (pm.d > tolerance) {
                r.violations.push_back(mid);
                reach(bound, mid);
                continue;
            }
            stack.emplace_back(pm, p1);
            stack.emplace_back(p0, pm);
        }
    }
    r.bound = min2(r.bound, kPi);  // no two rotations are farther apart
    std::sort(r.violations.begin(), r.violations.end());
    r.violations.erase(std::unique(r.violations.begin(), r.violations.end()), r.violations.end());
    std::sort(r.unproven.begin(), r.unproven.end());
    return r;
}

void tighten_proof(const Motion& a, const Motion& b, const std::vector<double>& times, double min_step,
                   std::size_t max_evaluations, PlaybackBound& proof) {
    if (proof.proven()) return;
    double level = 1.05 * proof.max_evaluated;
    for (int i = 0; i < 6 && level < proof.bound; ++i) {
        const PlaybackBound again = prove_within(a, b, times, level, min_step, max_evaluations);
        proof.evaluations += again.evaluations;
        proof.max_evaluated = max2(proof.max_evaluated, again.max_evaluated);
        if (again.bound < proof.bound) {
            proof.bound = again.bound;
            proof.worst_time = again.worst_time;
        }
        if (again.proven()) break;
        level = max2(1.5 * level, 1.05 * again.max_evaluated);
    }
}

}  // namespace quatcurve
