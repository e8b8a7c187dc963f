// Real orthonormal spherical harmonics, bands 0..2, in the order and with the
// constants of SPEC.md section 5 (three.js SphericalHarmonics3; Ramamoorthi and
// Hanrahan 2001, "An Efficient Representation for Irradiance Environment Maps").
#pragma once
#include <array>

#include "iblbake/math/vec3.h"

namespace iblbake {

using Sh9 = std::array<double, 9>;

inline Sh9 sh9_basis(const Vec3d& d) {  // d: unit engine direction
    const double x = d.x, y = d.y, z = d.z;
    return {0.282095,
            0.488603 * y,
            0.488603 * z,
            0.488603 * x,
            1.092548 * x * y,
            1.092548 * y * z,
            0.315392 * (3.0 * z * z - 1.0),
            1.092548 * x * z,
            0.546274 * (x * x - y * y)};
}

// Convolution with the clamped cosine, divided by pi (SPEC stores Irr / pi):
// A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4.
inline double sh9_band_factor(int index) {
    return index == 0 ? 1.0 : (index < 4 ? 2.0 / 3.0 : 0.25);
}

// Irr(n) ~ sum (A_l / pi) L_lm Y_lm(n) for one colour channel.
inline double sh9_irradiance(const Sh9& coeffs, const Vec3d& n) {
    const Sh9 y = sh9_basis(n);
    double sum = 0.0;
    for (int i = 0; i < 9; ++i) sum += sh9_band_factor(i) * coeffs[i] * y[i];
    return sum;
}

}  // namespace iblbake
