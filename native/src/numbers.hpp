// Constants shared by the implementation files (private: not part of the public headers, so a file
// with its own copy still compiles beside it).
#pragma once

namespace quatcurve::numbers {

inline constexpr double kPi = 3.141592653589793238462643383279502884;
inline constexpr double kTwoPi = 2.0 * kPi;

}  // namespace quatcurve::numbers
