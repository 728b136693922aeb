// Fitting Blender F-curves through an animator's keys (the add-on's fit and live refit): the samples
// a fit matches, the channel values along the curve that join the keys as keyed, and the solver.
//
// One call does what a refit computes, without Python in between (so worker threads run it whole,
// without the GIL): Curve (the method through the keys) → samples every 1/subframes frame and at
// every key → channel values of the target's rotation mode → fit_keys with the keys forced.
#pragma once

#include <cstddef>
#include <vector>

#include "quatcurve/channels.hpp"
#include "quatcurve/curve.hpp"
#include "quatcurve/reduce.hpp"

namespace quatcurve {

// The samples a fit matches: every 1/subframes frame from the first key to the last (1e-9 of slack
// at the ends) without grid points within 1e-6 frames of a key, merged with the key frames (sorted,
// unique). key_frames must increase; subframes ≥ 1.
std::vector<double> fit_sample_frames(const std::vector<double>& key_frames, int subframes);

struct KeyFit {
    std::vector<double> times;        // fit_sample_frames
    std::vector<std::size_t> forced;  // the index in `times` of every key
    ReducedKeys keys;                 // the fitted keys (fit_keys*)
};

// The fit of `curve` (through the keys at key_frames) in rotation mode `mode`: key_values holds K
// rows of channel_count(mode) values, as the fit writes them — quaternion keys with the sign the
// curve reaches them with, Euler and axis-angle keys as keyed (their turns are the curve's). The
// channel values between two keys follow the curve and join the keys as keyed:
// - QUATERNION: the curve's sign at the segment's first key, scaled by the two keys' norms
//   interpolated along the segment (stored non-unit keys stay as they are);
// - Euler: each segment continuous from its first key (quats_to_channels with that key as reference);
// - AXIS_ANGLE: axis_angle_span_channels from key to key, the axis scaled by the keys' axis lengths
//   interpolated along the segment.
// Then fit_keys (BEZIER, per channel) with every key forced; inserted keys keep min_gap frames from
// them. Throws InvalidArgument for fewer than two keys, mismatched sizes, and whatever the steps throw.
KeyFit fit_through_keys(const Curve& curve, const std::vector<double>& key_frames,
                        const std::vector<double>& key_values, const RotationMode& mode, int subframes,
                        double tolerance, double min_gap = 0.01);

}  // namespace quatcurve
