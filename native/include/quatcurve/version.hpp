#pragma once

namespace quatcurve {
inline constexpr const char* kVersion = "0.1.0";
}
