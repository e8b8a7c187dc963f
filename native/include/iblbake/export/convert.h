// Conventions between SPEC's cubes and SH and what an engine reads (ENGINES.md
// section 1): face mirrors, SH sign flips, Filament's pre-scaled SH and
// Babylon's spherical polynomial. Small pure functions, no I/O.
#pragma once
#include <array>

#include "iblbake/export/preset.h"
#include "iblbake/image/image.h"
#include "iblbake/math/sh.h"

namespace iblbake {

// Where texel (i, j) of face f of a mirrored cube comes from in the SPEC cube
// (an involution): the cube that holds at direction (X, Y, Z) the value SPEC
// holds at (-X, Y, Z) (Mirror::X) or at (X, Y, -Z) (Mirror::Z).
struct TexelRef {
    int face, i, j;
};
TexelRef mirror_source(Mirror m, int face, int i, int j, int n);
// The whole cube remapped that way.
Cubemap mirror_cube(const Cubemap& cube, Mirror m);
// Row j of face f of the mirrored cube, read from the SPEC cube without a
// copy: its first texel and the step between texels (3 floats, or -3 where
// the mirror reverses rows).
struct RowSource {
    const float* first;
    std::ptrdiff_t step;
};
RowSource mirrored_row(const Cubemap& cube, Mirror m, int face, int j);

// SH9 (SPEC section 5 order) of the mirrored radiance: x negates the
// coefficients odd in x (3, 4, 7), z those odd in z (2, 5, 7).
Sh9 mirror_sh9(const Sh9& sh, Mirror m);
std::array<Sh9, 3> mirror_sh9(const std::array<Sh9, 3>& sh, Mirror m);

// k_i = (A_l / pi) c_lm: Irr(n) = sum k_i L_i P_i(n) with P = 1, y, z, x, xy,
// yz, 3z^2 - 1, xz, x^2 - y^2.
extern const std::array<double, 9> kIrradianceShScale;
// Filament's pre-scaled SH (its `sh` key, IndirectLight::irradiance(3, sh)):
// L_i k_i per channel.
std::array<Sh9, 3> filament_sh(const std::array<Sh9, 3>& sh9);

// Babylon's SphericalPolynomial, x X + y Y + z Z + xx X^2 + yy Y^2 + zz Z^2 +
// yz YZ + zx ZX + xy XY (per channel): the SH9 irradiance written as a
// quadratic without constant (X^2 + Y^2 + Z^2 = 1), with bands 1 and 2 scaled
// by 2/3 and 1/4 because Babylon evaluates them 3/2 and 4 times stronger; so
// evaluate() gives Irr for band 0 only, and Babylon renders Irr.
struct Polynomial {
    std::array<double, 3> x, y, z, xx, yy, zz, yz, zx, xy;
};
Polynomial babylon_polynomial(const std::array<Sh9, 3>& sh9);
// Evaluates it (per channel) at a unit direction.
std::array<double, 3> evaluate(const Polynomial& p, const Vec3d& n);

}  // namespace iblbake
