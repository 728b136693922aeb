// Blender's F-curve evaluation of LINEAR and BEZIER keys, emulated operation for operation in float32
// (see blender_eval.hpp for what is emulated and the sources). The key reducer verifies its bound
// with this, so every float cast below is deliberate: Blender computes the cubic's coefficients in
// float and solves it in double.
#include "quatcurve/blender_eval.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "quatcurve/errors.hpp"

namespace quatcurve {
namespace {

constexpr double kSmall = -1.0e-10;         // solve_cubic's lower root bound (Blender's SMALL)
constexpr float kBinarySearchThresh = 0.0001f;  // fcurve_eval_keyframes_interpolate's threshold
constexpr float kKeyEps = 1.e-8f;           // "key directly on the frame" check

// Real cube root of d, as Blender's sqrt3d: exp(log|d|/3) with the sign of d, 0 for 0.
double sqrt3d(double d) {
    if (d == 0.0) return 0.0;
    if (d < 0.0) return -std::exp(std::log(-d) / 3.0);
    return std::exp(std::log(d) / 3.0);
}

bool in_unit(float r) { return r >= float(kSmall) && r <= 1.000001f; }

// Roots in [SMALL, 1.000001] of c0 + c1 x + c2 x² + c3 x³, written to o (float), count returned.
// Cardano for c3 ≠ 0 (one real root when the discriminant d > 0, trigonometric form for d < 0),
// then the quadratic and linear cases — Blender's solve_cubic exactly.
int solve_cubic(double c0, double c1, double c2, double c3, float* o) {
    double a, b, c, p, q, d, t, phi;
    int nr = 0;
    if (c3 != 0.0) {
        a = c2 / c3;
        b = c1 / c3;
        c = c0 / c3;
        a = a / 3;
        p = b / 3 - a * a;
        q = (2 * a * a * a - a * b + c) / 2;
        d = q * q + p * p * p;
        if (d > 0.0) {
            t = std::sqrt(d);
            o[0] = float(sqrt3d(-q + t) + sqrt3d(-q - t) - a);
            return in_unit(o[0]) ? 1 : 0;
        }
        if (d == 0.0) {
            t = sqrt3d(-q);
            o[0] = float(2 * t - a);
            if (in_unit(o[0])) nr++;
            o[nr] = float(-t - a);
            return in_unit(o[nr]) ? nr + 1 : nr;
        }
        phi = std::acos(-q / std::sqrt(-(p * p * p)));
        t = std::sqrt(-p);
        p = std::cos(phi / 3);
        q = std::sqrt(3 - 3 * p * p);
        o[0] = float(2 * t * p - a);
        if (in_unit(o[0])) nr++;
        o[nr] = float(-t * (p + q) - a);
        if (in_unit(o[nr])) nr++;
        o[nr] = float(-t * (p - q) - a);
        return in_unit(o[nr]) ? nr + 1 : nr;
    }
    a = c2;
    b = c1;
    c = c0;
    if (a != 0.0) {
        p = b * b - 4 * a * c;
        if (p > 0) {
            p = std::sqrt(p);
            o[0] = float((-b - p) / (2 * a));
            if (in_unit(o[0])) nr++;
            o[nr] = float((-b + p) / (2 * a));
            return in_unit(o[nr]) ? nr + 1 : nr;
        }
        if (p == 0) {
            o[0] = float(-b / (2 * a));
            if (in_unit(o[0])) return 1;
        }
        return 0;
    }
    if (b != 0.0) {
        o[0] = float(-c / b);
        return in_unit(o[0]) ? 1 : 0;
    }
    if (c == 0.0) {
        o[0] = 0.0f;
        return 1;
    }
    return 0;
}

// Parameters t where the Bezier's frame polynomial with control frames q0..q3 equals x. The
// coefficients are float expressions widened to double, as in Blender.
int findzero(float x, float q0, float q1, float q2, float q3, float* o) {
    const double c0 = q0 - x;
    const double c1 = 3.0f * (q1 - q0);
    const double c2 = 3.0f * (q0 - 2.0f * q1 + q2);
    const double c3 = q3 - q0 + 3.0f * (q1 - q2);
    return solve_cubic(c0, c1, c2, c3, o);
}

// The Bezier value polynomial with control values f1..f4 at parameter t, in float.
float berekeny(float f1, float f2, float f3, float f4, float t) {
    const float c0 = f1;
    const float c1 = 3.0f * (f2 - f1);
    const float c2 = 3.0f * (f1 - 2.0f * f2 + f3);
    const float c3 = f4 - f1 + 3.0f * (f2 - f3);
    return c0 + t * c1 + t * t * c2 + t * t * t * c3;
}

// Handles longer than the segment are scaled back to its length (Blender 2.9x+ form: each handle
// separately). The reducer's 1/3-spaced handles never trigger it; keys edited in Blender often do.
void correct_bezpart(const float v1[2], float v2[2], float v3[2], const float v4[2]) {
    float h1[2], h2[2];
    h1[0] = v1[0] - v2[0];
    h1[1] = v1[1] - v2[1];
    h2[0] = v4[0] - v3[0];
    h2[1] = v4[1] - v3[1];
    const float len = v4[0] - v1[0];
    const float len1 = std::fabs(h1[0]);
    const float len2 = std::fabs(h2[0]);
    if ((len1 + len2) == 0.0f) return;
    if (len1 > len) {
        const float fac = len / len1;
        v2[0] = (v1[0] - fac * h1[0]);
        v2[1] = (v1[1] - fac * h1[1]);
    }
    if (len2 > len) {
        const float fac = len / len2;
        v3[0] = (v4[0] - fac * h2[0]);
        v3[1] = (v4[1] - fac * h2[1]);
    }
}

bool is_eqt(float a, float b, float c) { return (a > b) ? ((a - b) <= c) : ((b - a) <= c); }

// BKE_fcurve_bezt_binarysearch_index_ex: index of the key within the threshold of frame (exact set)
// or the insertion index (first key after frame).
int binary_search(const std::vector<double>& frames, float frame, bool& exact) {
    const int n = static_cast<int>(frames.size());
    exact = false;
    float framenum = float(frames[0]);
    if (is_eqt(frame, framenum, kBinarySearchThresh)) {
        exact = true;
        return 0;
    }
    if (frame < framenum) return 0;
    framenum = float(frames[n - 1]);
    if (is_eqt(frame, framenum, kBinarySearchThresh)) {
        exact = true;
        return n - 1;
    }
    if (frame > framenum) return n;
    int start = 0, end = n;
    for (int loop = 0; start <= end && loop < n * 2; ++loop) {
        const int mid = start + ((end - start) / 2);
        const float midfra = float(frames[mid]);
        if (is_eqt(frame, midfra, kBinarySearchThresh)) {
            exact = true;
            return mid;
        }
        if (frame > midfra) {
            start = mid + 1;
        } else if (frame < midfra) {
            end = mid - 1;
        }
    }
    return start;
}

}  // namespace

KeyInterpolation parse_key_interpolation(const std::string& name) {
    if (name == "LINEAR") return KeyInterpolation::LINEAR;
    if (name == "BEZIER") return KeyInterpolation::BEZIER;
    throw InvalidArgument("interpolation: unknown interpolation '" + name +
                          "' (expected LINEAR or BEZIER)");
}

const char* key_interpolation_name(KeyInterpolation interpolation) {
    return interpolation == KeyInterpolation::LINEAR ? "LINEAR" : "BEZIER";
}

void check_fcurve_keys(const FCurveKeys& keys, KeyInterpolation interpolation) {
    const std::size_t n = keys.frames.size();
    if (keys.values.size() != n)
        throw InvalidArgument("values: " + std::to_string(keys.values.size()) + " values for " +
                              std::to_string(n) + " frames");
    // Blender stores float32: a number beyond its range would become inf there.
    // (The message is built only for the element refused: every playback the key reducer's proof
    // makes checks its keys, and building it for every element was most of that cost.)
    auto check = [](const std::vector<double>& v, const char* name, std::size_t stride) {
        for (std::size_t i = 0; i < v.size(); ++i) {
            if (std::isfinite(float(v[i])) && std::isfinite(v[i])) continue;
            const std::string where = std::string(name) + "[" + std::to_string(i / stride) +
                                      (stride == 2 ? (i % 2 ? ", 1]" : ", 0]") : "]");
            if (!std::isfinite(v[i])) throw InvalidArgument(where + ": non-finite value");
            throw InvalidArgument(where + ": beyond float32 range (Blender stores float32)");
        }
    };
    check(keys.frames, "frames", 1);
    check(keys.values, "values", 1);
    // Strictly increasing as float32: Blender keeps its keys sorted, and two keys on one frame make
    // its binary search ambiguous.
    for (std::size_t k = 1; k < n; ++k) {
        if (!(float(keys.frames[k]) > float(keys.frames[k - 1])))
            throw InvalidArgument("frames[" + std::to_string(k) +
                                  "]: not increasing (as float32, Blender's storage)");
    }
    if (interpolation == KeyInterpolation::BEZIER) {
        if (keys.handle_left.size() != 2 * n)
            throw InvalidArgument("handle_left: " + std::to_string(keys.handle_left.size() / 2) +
                                  " handles for " + std::to_string(n) + " keys");
        if (keys.handle_right.size() != 2 * n)
            throw InvalidArgument("handle_right: " + std::to_string(keys.handle_right.size() / 2) +
                                  " handles for " + std::to_string(n) + " keys");
        check(keys.handle_left, "handle_left", 2);
        check(keys.handle_right, "handle_right", 2);
    }
}

float blender_evaluate(const FCurveKeys& ch, KeyInterpolation interpolation, float evaltime) {
    const std::size_t n = ch.frames.size();
    if (n == 0) return 0.0f;
    // fcurve_eval_keyframes: constant extrapolation at and beyond the end keys.
    if (evaltime <= float(ch.frames[0])) return float(ch.values[0]);
    if (float(ch.frames[n - 1]) <= evaltime) return float(ch.values[n - 1]);

    bool exact = false;
    const int a = binary_search(ch.frames, evaltime, exact);
    if (exact) return float(ch.values[a]);
    const int prev = a > 0 ? a - 1 : a;
    const float bx = float(ch.frames[a]), by = float(ch.values[a]);
    const float px = float(ch.frames[prev]), py = float(ch.values[prev]);
    if (std::fabs(bx - evaltime) < kKeyEps) return by;
    if (evaltime < px || bx < evaltime) return 0.0f;

    const float begin = py;
    const float change = by - py;
    const float duration = bx - px;
    const float time = evaltime - px;
    if (duration == 0) return py;

    if (interpolation == KeyInterpolation::LINEAR) return change * time / duration + begin;

    float v1[2] = {px, py};
    float v2[2] = {float(ch.handle_right[2 * prev]), float(ch.handle_right[2 * prev + 1])};
    float v3[2] = {float(ch.handle_left[2 * a]), float(ch.handle_left[2 * a + 1])};
    float v4[2] = {bx, by};
    const float flt_eps = 1.1920928955078125e-07f;  // FLT_EPSILON
    if (std::fabs(v1[1] - v4[1]) < flt_eps && std::fabs(v2[1] - v3[1]) < flt_eps &&
        std::fabs(v3[1] - v4[1]) < flt_eps) {
        return v1[1];  // Blender's flat-segment shortcut
    }
    correct_bezpart(v1, v2, v3, v4);
    float opl[32];
    if (!findzero(evaltime, v1[0], v2[0], v3[0], v4[0], opl)) return 0.0f;
    return berekeny(v1[1], v2[1], v3[1], v4[1], opl[0]);
}

// blender_evaluate's steps, the search and the root finder shared between the channels.
void blender_evaluate_shared(const FCurveKeys* const* channels, int count, KeyInterpolation interpolation,
                             float evaltime, double* out) {
    const std::size_t C = static_cast<std::size_t>(count);
    const std::vector<double>& frames = channels[0]->frames;
    const std::size_t n = frames.size();
    if (n == 0) {
        for (std::size_t c = 0; c < C; ++c) out[c] = 0.0;
        return;
    }
    if (evaltime <= float(frames[0]) || float(frames[n - 1]) <= evaltime) {
        const std::size_t k = evaltime <= float(frames[0]) ? 0 : n - 1;
        for (std::size_t c = 0; c < C; ++c) out[c] = float(channels[c]->values[k]);
        return;
    }
    bool exact = false;
    const int a = binary_search(frames, evaltime, exact);
    const int prev = a > 0 ? a - 1 : a;
    const float bx = float(frames[a]), px = float(frames[prev]);
    const float duration = bx - px, time = evaltime - px;
    const float flt_eps = 1.1920928955078125e-07f;  // FLT_EPSILON
    bool found = false, root = false;  // the root found last, and the handle frames it was found for
    float u = 0.0f, q1 = 0.0f, q2 = 0.0f;
    for (std::size_t c = 0; c < C; ++c) {
        const FCurveKeys& ch = *channels[c];
        const float by = float(ch.values[a]), py = float(ch.values[prev]);
        if (exact) {
            out[c] = by;
        } else if (std::fabs(bx - evaltime) < kKeyEps) {
            out[c] = by;
        } else if (evaltime < px || bx < evaltime) {
            out[c] = 0.0f;
        } else if (duration == 0) {
            out[c] = py;
        } else if (interpolation == KeyInterpolation::LINEAR) {
            out[c] = (by - py) * time / duration + py;
        } else {
            float v1[2] = {px, py};
            float v2[2] = {float(ch.handle_right[2 * prev]), float(ch.handle_right[2 * prev + 1])};
            float v3[2] = {float(ch.handle_left[2 * a]), float(ch.handle_left[2 * a + 1])};
            float v4[2] = {bx, by};
            if (std::fabs(v1[1] - v4[1]) < flt_eps && std::fabs(v2[1] - v3[1]) < flt_eps &&
                std::fabs(v3[1] - v4[1]) < flt_eps) {
                out[c] = v1[1];  // Blender's flat-segment shortcut
                continue;
            }
            correct_bezpart(v1, v2, v3, v4);
            if (!found || v2[0] != q1 || v3[0] != q2) {
                float opl[32];
                root = findzero(evaltime, v1[0], v2[0], v3[0], v4[0], opl) != 0;
                if (root) u = opl[0];
                q1 = v2[0], q2 = v3[0];
                found = true;
            }
            out[c] = root ? berekeny(v1[1], v2[1], v3[1], v4[1], u) : 0.0f;
        }
    }
}

void blender_evaluate(const FCurveKeys& channel, KeyInterpolation interpolation,
                      const std::vector<double>& frames, std::vector<double>& out) {
    if (std::is_sorted(frames.begin(), frames.end())) {
        blender_evaluate_sorted(channel, interpolation, frames, out);
        return;
    }
    out.resize(frames.size());
    for (std::size_t k = 0; k < frames.size(); ++k)
        out[k] = blender_evaluate(channel, interpolation, float(frames[k]));
}

// One walk over the keys instead of a binary search per frame (frames strictly increasing). A frame farther than 2e-4 from both
// keys around it cannot be within Blender's 1e-4 threshold of any key, so Blender's search lands on
// that segment; frames nearer a key go through blender_evaluate itself. The Bezier parameter
// depends only on frames, so channels with the same key frames can share it (param_cache, reuse).
void blender_evaluate_sorted(const FCurveKeys& ch, KeyInterpolation interpolation,
                             const std::vector<double>& frames, std::vector<double>& out,
                             std::vector<float>* param_cache, bool reuse) {
    const std::size_t m = frames.size(), n = ch.frames.size();
    out.assign(m, 0.0);
    if (param_cache && !reuse) param_cache->assign(m, -1.0f);
    if (n == 0) return;
    const float first = float(ch.frames[0]), last = float(ch.frames[n - 1]);
    std::size_t a = 1;
    for (std::size_t s = 0; s < m; ++s) {
        const float e = float(frames[s]);
        if (e <= first) {
            out[s] = float(ch.values[0]);
            continue;
        }
        if (last <= e) {
            out[s] = float(ch.values[n - 1]);
            continue;
        }
        while (float(ch.frames[a]) <= e) ++a;  // first key after e (exists: e < last)
        const std::size_t prev = a - 1;
        const float px = float(ch.frames[prev]), bx = float(ch.frames[a]);
        if (e == px) {  // on a key: Blender's search always finds an exactly equal key
            out[s] = float(ch.values[prev]);
            continue;
        }
        if (e - px <= 2e-4f || bx - e <= 2e-4f) {
            out[s] = blender_evaluate(ch, interpolation, e);
            continue;
        }
        const float py = float(ch.values[prev]), by = float(ch.values[a]);
        const float duration = bx - px;
        if (duration == 0) {
            out[s] = py;
            continue;
        }
        if (interpolation == KeyInterpolation::LINEAR) {
            out[s] = (by - py) * (e - px) / duration + py;
            continue;
        }
        float v1[2] = {px, py};
        float v2[2] = {float(ch.handle_right[2 * prev]), float(ch.handle_right[2 * prev + 1])};
        float v3[2] = {float(ch.handle_left[2 * a]), float(ch.handle_left[2 * a + 1])};
        float v4[2] = {bx, by};
        const float flt_eps = 1.1920928955078125e-07f;
        if (std::fabs(v1[1] - v4[1]) < flt_eps && std::fabs(v2[1] - v3[1]) < flt_eps &&
            std::fabs(v3[1] - v4[1]) < flt_eps) {
            out[s] = v1[1];
            continue;
        }
        correct_bezpart(v1, v2, v3, v4);
        float u;
        if (param_cache && reuse && (*param_cache)[s] >= 0.0f) {
            u = (*param_cache)[s];
        } else {
            float opl[32];
            if (!findzero(e, v1[0], v2[0], v3[0], v4[0], opl)) {
                out[s] = 0.0f;
                continue;
            }
            u = opl[0];
            if (param_cache) (*param_cache)[s] = u;
        }
        out[s] = berekeny(v1[1], v2[1], v3[1], v4[1], u);
    }
}

// The walk of blender_evaluate_sorted once for channels with the same key frames. A segment's control
// points (after correct_bezpart) and Blender's flat-segment test are taken per channel when the walk
// enters it; the parameter of a frame is found once and reused by every channel whose corrected
// handle frames equal the ones it was found for (findzero depends on nothing else).
void blender_evaluate_sorted_shared(const FCurveKeys* const* channels, int count,
                                    KeyInterpolation interpolation, const std::vector<double>& frames,
                                    double* out, std::size_t stride) {
    const std::size_t m = frames.size(), n = channels[0]->frames.size();
    const std::size_t C = static_cast<std::size_t>(count);
    if (n == 0) {
        for (std::size_t s = 0; s < m; ++s)
            for (std::size_t c = 0; c < C; ++c) out[s * stride + c] = 0.0;
        return;
    }
    const std::vector<double>& keys = channels[0]->frames;
    const float first = float(keys[0]), last = float(keys[n - 1]);
    struct Segment {
        float v1[2], v2[2], v3[2], v4[2];
        bool flat;  // Blender's flat-segment shortcut: the value is v1[1]
    };
    std::vector<Segment> seg(C);
    std::size_t a = 1, seg_a = 0;  // seg holds the segment ending at key seg_a (0: none yet)
    for (std::size_t s = 0; s < m; ++s) {
        double* o = out + s * stride;
        const float e = float(frames[s]);
        if (e <= first) {
            for (std::size_t c = 0; c < C; ++c) o[c] = float(channels[c]->values[0]);
            continue;
        }
        if (last <= e) {
            for (std::size_t c = 0; c < C; ++c) o[c] = float(channels[c]->values[n - 1]);
            continue;
        }
        while (float(keys[a]) <= e) ++a;  // first key after e (exists: e < last)
        const std::size_t prev = a - 1;
        const float px = float(keys[prev]), bx = float(keys[a]);
        if (e == px) {  // on a key: Blender's search always finds an exactly equal key
            for (std::size_t c = 0; c < C; ++c) o[c] = float(channels[c]->values[prev]);
            continue;
        }
        if (e - px <= 2e-4f || bx - e <= 2e-4f) {
            for (std::size_t c = 0; c < C; ++c) o[c] = blender_evaluate(*channels[c], interpolation, e);
            continue;
        }
        const float duration = bx - px;
        if (duration == 0) {
            for (std::size_t c = 0; c < C; ++c) o[c] = float(channels[c]->values[prev]);
            continue;
        }
        if (interpolation == KeyInterpolation::LINEAR) {
            for (std::size_t c = 0; c < C; ++c) {
                const float py = float(channels[c]->values[prev]), by = float(channels[c]->values[a]);
                o[c] = (by - py) * (e - px) / duration + py;
            }
            continue;
        }
        if (seg_a != a) {
            seg_a = a;
            const float flt_eps = 1.1920928955078125e-07f;  // FLT_EPSILON
            for (std::size_t c = 0; c < C; ++c) {
                const FCurveKeys& ch = *channels[c];
                Segment& g = seg[c];
                g.v1[0] = px, g.v1[1] = float(ch.values[prev]);
                g.v2[0] = float(ch.handle_right[2 * prev]), g.v2[1] = float(ch.handle_right[2 * prev + 1]);
                g.v3[0] = float(ch.handle_left[2 * a]), g.v3[1] = float(ch.handle_left[2 * a + 1]);
                g.v4[0] = bx, g.v4[1] = float(ch.values[a]);
                g.flat = std::fabs(g.v1[1] - g.v4[1]) < flt_eps && std::fabs(g.v2[1] - g.v3[1]) < flt_eps &&
                         std::fabs(g.v3[1] - g.v4[1]) < flt_eps;
                if (!g.flat) correct_bezpart(g.v1, g.v2, g.v3, g.v4);
            }
        }
        // The parameter found last at this frame and the handle frames it was found for.
        bool found = false, root = false;
        float u = 0.0f, q1 = 0.0f, q2 = 0.0f;
        for (std::size_t c = 0; c < C; ++c) {
            const Segment& g = seg[c];
            if (g.flat) {
                o[c] = g.v1[1];
                continue;
            }
            if (!found || g.v2[0] != q1 || g.v3[0] != q2) {
                float opl[32];
                root = findzero(e, g.v1[0], g.v2[0], g.v3[0], g.v4[0], opl) != 0;
                if (root) u = opl[0];
                q1 = g.v2[0], q2 = g.v3[0];
                found = true;
            }
            o[c] = root ? berekeny(g.v1[1], g.v2[1], g.v3[1], g.v4[1], u) : 0.0f;
        }
    }
}

// Used by the reducer to refit with Blender's own frame→parameter map when float32 handle frames
// make it slightly non-linear.
float blender_bezier_parameter(float frame, float q0, float q1, float q2, float q3) {
    float opl[32];
    if (!findzero(frame, q0, q1, q2, q3, opl)) return -1.0f;
    return opl[0];
}

}  // namespace quatcurve
