// Branch-light approximations for hot loops, each with its error bound
// (checked in tests/native/test_geometry.cpp).
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

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

// float(std::acos(x)) for x in [-1, 1], the same float to the bit, cheaper
// for the small angles of the bin tree's fine bins. For x >= 0.98 (angles up
// to 0.2 rad): acos x = 2 asin s, s = sqrt((1 - x) / 2) (1 - x is exact for
// x >= 0.5, the root correctly rounded), asin s by its series to s^15
// (truncated under 2e-18 relative at s = 0.1): within 1e-15 of the angle,
// relative, as the library's is within an ulp of it. Both then round to the
// same float unless the angle lies within 1e-13 of it from halfway between
// two floats; there, and for every other x, std::acos is called
// (tests/native/test_geometry.cpp compares the two on 4.2 million x).
inline float acos_float(double x) {
    if (x >= 0.98 && x < 1.0) {
        const double s2 = 0.5 * (1.0 - x), s = std::sqrt(s2);
        double p = 143.0 / 10240.0;
        p = p * s2 + 231.0 / 13312.0;
        p = p * s2 + 63.0 / 2816.0;
        p = p * s2 + 35.0 / 1152.0;
        p = p * s2 + 5.0 / 112.0;
        p = p * s2 + 3.0 / 40.0;
        p = p * s2 + 1.0 / 6.0;
        const double y = 2.0 * (s + s * (s2 * p));
        const float f = float(y);  // > 0: y >= 2 sqrt(2^-54)
        uint32_t bits;
        std::memcpy(&bits, &f, sizeof(bits));
        float lo, hi;
        const uint32_t below = bits - 1u, above = bits + 1u;
        std::memcpy(&lo, &below, sizeof(lo));
        std::memcpy(&hi, &above, sizeof(hi));
        const double tol = 1e-13 * y;
        if (y - 0.5 * (double(lo) + double(f)) > tol && 0.5 * (double(f) + double(hi)) - y > tol) return f;
    }
    return float(std::acos(x));
}

// atan2(y, x) in double without a library call, so that loops of it
// vectorise: Cephes' atan (a rational function of degree 9 / 10 after
// reduction to [0, 0.66] or through pi/4 + atan((a - 1) / (a + 1))), on
// a = min / max of |x|, |y|, then the quadrant. Within 2 ulp of std::atan2
// (tests/native/test_geometry.cpp); (0, 0) gives 0. Internal linkage
// (static): the row kernels built once per instruction set use it, and each
// unit must keep its own copy (an inline function's one shared copy could
// come from the AVX-512 unit).
static inline double atan2_vec(double y, double x) {
    const double ax = std::fabs(x), ay = std::fabs(y);
    const double hi = ax > ay ? ax : ay, lo = ax > ay ? ay : ax;
    const double a = hi > 0.0 ? lo / hi : 0.0;
    const bool mid = a > 0.66;
    const double t = mid ? (a - 1.0) / (a + 1.0) : a;
    const double z = t * t;
    const double p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z - 7.500855792314704667340e1) * z -
                      1.228866684490136173410e2) * z - 6.485021904942025371773e1;
    const double q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z + 4.328810604912902668951e2) *
                      z + 4.853903996359136964868e2) * z + 1.945506571482613964425e2;
    double r = t + t * z * p / q;
    r += mid ? 0.78539816339744830962 + 0.5 * 6.123233995736765886130e-17 : 0.0;
    r = ay > ax ? 1.57079632679489661923 - r : r;
    r = x < 0.0 ? 3.14159265358979323846 - r : r;
    return y < 0.0 ? -r : r;
}

}  // namespace iblbake
