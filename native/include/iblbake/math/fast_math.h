// Branch-light approximations for hot loops, each with its error bound
// (checked in tests/native/test_geometry.cpp).
#pragma once
#include <cmath>

namespace iblbake {

// acos(x) for x in [-1, 1], |error| <= 2e-7 rad in float: Abramowitz and
// Stegun 4.4.46, acos(x) = sqrt(1 - x) * poly(x) for x >= 0, mirrored for x < 0.
inline float fast_acos(float x) {
    const float a = std::fabs(x) < 1.0f ? std::fabs(x) : 1.0f;
    float p = -0.0012624911f;
    p = p * a + 0.0066700901f;
    p = p * a - 0.0170881256f;
    p = p * a + 0.0308918810f;
    p = p * a - 0.0501743046f;
    p = p * a + 0.0889789874f;
    p = p * a - 0.2145988016f;
    p = p * a + 1.5707963050f;
    const float r = std::sqrt(1.0f - a) * p;
    return x >= 0.0f ? r : 3.14159265358979f - r;
}

}  // namespace iblbake
