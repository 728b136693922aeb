// Blender's F-curve evaluation, emulated (blender_eval.hpp): closed forms, Blender's special cases
// (thresholds around keys, flat segments, long handles), the sorted sweep against the pointwise form,
// and the argument checks. Against Blender itself: tests/blender/test_blender_eval.py.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "quatcurve/blender_eval.hpp"
#include "quatcurve/errors.hpp"

using namespace quatcurve;

namespace {

FCurveKeys make_keys(std::vector<double> frames, std::vector<double> values) {
    FCurveKeys ch;
    ch.frames = std::move(frames);
    ch.values = std::move(values);
    return ch;
}

template <class F>
void expect_invalid(F&& f, const std::string& fragment) {
    try {
        f();
        ADD_FAILURE() << "no InvalidArgument (expected '" << fragment << "')";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
}

}  // namespace

TEST(BlenderEval, ParseInterpolation) {
    EXPECT_EQ(parse_key_interpolation("LINEAR"), KeyInterpolation::LINEAR);
    EXPECT_EQ(parse_key_interpolation("BEZIER"), KeyInterpolation::BEZIER);
    EXPECT_STREQ(key_interpolation_name(KeyInterpolation::BEZIER), "BEZIER");
    expect_invalid([] { parse_key_interpolation("CUBIC"); }, "interpolation: unknown");
}

TEST(BlenderEval, LinearSegmentsAndConstantExtrapolation) {
    const FCurveKeys ch = make_keys({0.0, 10.0, 20.0}, {0.0, 1.0, -1.0});
    EXPECT_FLOAT_EQ(blender_evaluate(ch, KeyInterpolation::LINEAR, 2.5f), 0.25f);
    EXPECT_FLOAT_EQ(blender_evaluate(ch, KeyInterpolation::LINEAR, 15.0f), 0.0f);
    EXPECT_FLOAT_EQ(blender_evaluate(ch, KeyInterpolation::LINEAR, -5.0f), 0.0f);
    EXPECT_FLOAT_EQ(blender_evaluate(ch, KeyInterpolation::LINEAR, 25.0f), -1.0f);
    EXPECT_FLOAT_EQ(blender_evaluate(ch, KeyInterpolation::LINEAR, 10.0f), 1.0f);
    // Within Blender's 1e-4-frame threshold of a key: the key's value.
    EXPECT_FLOAT_EQ(blender_evaluate(ch, KeyInterpolation::LINEAR, 10.00005f), 1.0f);
    const FCurveKeys one = make_keys({3.0}, {0.7});
    EXPECT_FLOAT_EQ(blender_evaluate(one, KeyInterpolation::BEZIER, 100.0f), 0.7f);
    EXPECT_FLOAT_EQ(blender_evaluate(FCurveKeys{}, KeyInterpolation::LINEAR, 1.0f), 0.0f);
}

TEST(BlenderEval, BezierWithThirdHandlesIsTheCubicInTheParameter) {
    // Handle frames at exactly 1/3 and 2/3 (representable): frame is linear in u, the value is the
    // Bernstein cubic.
    FCurveKeys ch = make_keys({0.0, 3.0}, {0.2, -0.5});
    ch.handle_left = {-1.0, 0.2, 2.0, 0.9};
    ch.handle_right = {1.0, -0.7, 4.0, -0.5};
    for (double u : {0.1, 0.25, 0.5, 0.8, 0.95}) {
        const double v = 1 - u;
        const double expected = v * v * v * 0.2 + 3 * v * v * u * -0.7 + 3 * v * u * u * 0.9 +
                                u * u * u * -0.5;
        // float32 power-basis evaluation (berekeny) rounds to ~1e-6 here.
        EXPECT_NEAR(blender_evaluate(ch, KeyInterpolation::BEZIER, float(3.0 * u)), expected, 1.5e-6)
            << "u = " << u;
        EXPECT_NEAR(blender_bezier_parameter(float(3.0 * u), 0.0f, 1.0f, 2.0f, 3.0f), u, 1e-7);
    }
    // A flat segment takes Blender's shortcut (the key's value).
    FCurveKeys flat = make_keys({0.0, 3.0}, {0.5, 0.5});
    flat.handle_left = {-1.0, 0.5, 2.0, 0.5};
    flat.handle_right = {1.0, 0.5, 4.0, 0.5};
    EXPECT_EQ(blender_evaluate(flat, KeyInterpolation::BEZIER, 1.3f), 0.5f);
}

TEST(BlenderEval, SortedSweepEqualsPointwiseEvaluation) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> val(-1.0, 1.0), gap(0.3, 4.0);
    FCurveKeys ch;
    double f = 10.0;
    for (int a = 0; a < 40; ++a) {
        ch.frames.push_back(double(float(f)));
        ch.values.push_back(double(float(val(rng))));
        f += gap(rng);
    }
    for (std::size_t a = 0; a < ch.frames.size(); ++a) {
        const double dl = a > 0 ? ch.frames[a] - ch.frames[a - 1] : 1.0;
        const double dr = a + 1 < ch.frames.size() ? ch.frames[a + 1] - ch.frames[a] : 1.0;
        ch.handle_left.push_back(double(float(ch.frames[a] - dl / 3)));
        ch.handle_left.push_back(double(float(val(rng))));
        ch.handle_right.push_back(double(float(ch.frames[a] + dr / 3)));
        ch.handle_right.push_back(double(float(val(rng))));
    }
    std::vector<double> at;
    for (double x = 5.0; x < f + 5.0; x += 0.173) at.push_back(x);
    for (double key : ch.frames) {  // on, and within the threshold of, every key
        at.push_back(key);
        at.push_back(key + 0.00005);
        at.push_back(key - 0.00015);
    }
    std::sort(at.begin(), at.end());
    for (KeyInterpolation ipo : {KeyInterpolation::LINEAR, KeyInterpolation::BEZIER}) {
        std::vector<double> swept;
        blender_evaluate_sorted(ch, ipo, at, swept);
        for (std::size_t k = 0; k < at.size(); ++k)
            ASSERT_EQ(swept[k], double(blender_evaluate(ch, ipo, float(at[k])))) << "frame " << at[k];
    }
}

TEST(BlenderEval, SharedSweepAndPointEqualEachChannelOnItsOwn) {
    // Three channels on the same key frames: values and handle values differ, one channel is flat
    // on some segments (Blender's shortcut), and the third has other (long) handle frames on one
    // segment, so its parameter must be found on its own there.
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> val(-1.0, 1.0), gap(0.3, 4.0);
    FCurveKeys chans[3];
    double f = 10.0;
    for (int a = 0; a < 30; ++a) {
        for (int c = 0; c < 3; ++c) {
            chans[c].frames.push_back(double(float(f)));
            chans[c].values.push_back(c == 1 && a % 5 < 2 ? 0.25 : double(float(val(rng))));
        }
        f += gap(rng);
    }
    for (std::size_t a = 0; a < chans[0].frames.size(); ++a) {
        const std::vector<double>& fr = chans[0].frames;
        const double dl = a > 0 ? fr[a] - fr[a - 1] : 1.0;
        const double dr = a + 1 < fr.size() ? fr[a + 1] - fr[a] : 1.0;
        for (int c = 0; c < 3; ++c) {
            const bool flat = c == 1 && a % 5 < 2;
            const double stretch = c == 2 && a == 7 ? 2.5 : 1.0 / 3;
            chans[c].handle_left.push_back(double(float(fr[a] - dl / 3)));
            chans[c].handle_left.push_back(flat ? 0.25 : double(float(val(rng))));
            chans[c].handle_right.push_back(double(float(fr[a] + dr * stretch)));
            chans[c].handle_right.push_back(flat ? 0.25 : double(float(val(rng))));
        }
    }
    std::vector<double> at;
    for (double x = 5.0; x < f + 5.0; x += 0.173) at.push_back(x);
    for (double key : chans[0].frames) {
        at.push_back(key);
        at.push_back(key + 0.00005);
        at.push_back(key - 0.00015);
    }
    std::sort(at.begin(), at.end());
    const FCurveKeys* ptrs[3] = {&chans[0], &chans[1], &chans[2]};
    for (KeyInterpolation ipo : {KeyInterpolation::LINEAR, KeyInterpolation::BEZIER}) {
        std::vector<double> shared(3 * at.size());
        blender_evaluate_sorted_shared(ptrs, 3, ipo, at, shared.data(), 3);
        for (int c = 0; c < 3; ++c) {
            std::vector<double> alone;
            blender_evaluate_sorted(chans[c], ipo, at, alone);
            for (std::size_t k = 0; k < at.size(); ++k)
                ASSERT_EQ(shared[3 * k + c], alone[k]) << "channel " << c << ", frame " << at[k];
        }
        // The pointwise form (PlaybackMotion's), in any order: each frame as blender_evaluate.
        for (std::size_t k = at.size(); k-- > 0;) {
            double point[3];
            blender_evaluate_shared(ptrs, 3, ipo, float(at[k]), point);
            for (int c = 0; c < 3; ++c)
                ASSERT_EQ(point[c], double(blender_evaluate(chans[c], ipo, float(at[k]))))
                    << "channel " << c << ", frame " << at[k];
        }
    }
}

TEST(BlenderEval, LongHandlesAreScaledBackToTheSegment) {
    // The first key's right handle reaches 30 frames into a 10-frame segment: Blender scales it back
    // to length 10 at evaluation, frame and value by the same factor 10/30 ((30, 6) → (10, 2)), so
    // the curve is the one with that handle stored (up to float32 rounding of the factor).
    FCurveKeys longer = make_keys({0.0, 10.0}, {0.0, 1.0});
    longer.handle_left = {-1.0, 0.0, 9.0, 1.0};
    longer.handle_right = {30.0, 6.0, 11.0, 1.0};
    FCurveKeys scaled = longer;
    scaled.handle_right[0] = 10.0;  // fac = 10/30
    scaled.handle_right[1] = 2.0;
    for (double f = 0.25; f < 10.0; f += 0.5) {
        EXPECT_NEAR(blender_evaluate(longer, KeyInterpolation::BEZIER, float(f)),
                    blender_evaluate(scaled, KeyInterpolation::BEZIER, float(f)), 1e-6)
            << "frame " << f;
    }
    // The stored handles are untouched.
    EXPECT_EQ(longer.handle_right[0], 30.0);
}

TEST(BlenderEval, WithinTheKeyThresholdTheKeyWins) {
    // Blender's search treats frames within 1e-4 of a key as that key, on both sides.
    FCurveKeys ch = make_keys({0.0, 1.0, 2.0}, {0.0, 1.0, 0.0});
    for (float f : {0.99991f, 1.0f, 1.00009f})
        EXPECT_EQ(blender_evaluate(ch, KeyInterpolation::LINEAR, f), 1.0f) << f;
    EXPECT_LT(blender_evaluate(ch, KeyInterpolation::LINEAR, 1.0002f), 1.0f);
}

TEST(BlenderEval, CheckFCurveKeysNamesTheElement) {
    FCurveKeys ok = make_keys({0.0, 1.0}, {0.0, 1.0});
    check_fcurve_keys(ok, KeyInterpolation::LINEAR);
    expect_invalid([&] { check_fcurve_keys(ok, KeyInterpolation::BEZIER); }, "handle_left: 0 handles for 2 keys");
    FCurveKeys bad = ok;
    bad.values.push_back(2.0);
    expect_invalid([&] { check_fcurve_keys(bad, KeyInterpolation::LINEAR); }, "values: 3 values for 2 frames");
    bad = ok;
    bad.frames[1] = 0.0;
    expect_invalid([&] { check_fcurve_keys(bad, KeyInterpolation::LINEAR); }, "frames[1]: not increasing");
    bad = ok;
    bad.values[0] = NAN;
    expect_invalid([&] { check_fcurve_keys(bad, KeyInterpolation::LINEAR); }, "values[0]: non-finite");
    bad = ok;
    bad.values[1] = 1e39;
    expect_invalid([&] { check_fcurve_keys(bad, KeyInterpolation::LINEAR); }, "values[1]: beyond float32");
    bad = ok;
    bad.handle_left = {-1.0, 0.0, 0.5, 1.0};
    bad.handle_right = {0.5, 0.0, 2.0, INFINITY};
    expect_invalid([&] { check_fcurve_keys(bad, KeyInterpolation::BEZIER); }, "handle_right[1, 1]: non-finite");
}
