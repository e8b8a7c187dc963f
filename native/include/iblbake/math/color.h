// Colour transfer functions. No I/O.
#pragma once
#include <cmath>

namespace iblbake {

inline float srgb_to_linear(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}
inline float linear_to_srgb(float c) {
    if (!(c > 0.0f)) return 0.0f;  // also maps NaN to 0
    if (c >= 1.0f) return 1.0f;
    return c <= 0.0031308f ? c * 12.92f : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

}  // namespace iblbake
