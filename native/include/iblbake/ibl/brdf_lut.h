// Split-sum BRDF integration LUT (SPEC.md section 3; Karis 2013).
#pragma once
#include <string>

#include "iblbake/image/image.h"

namespace iblbake {

enum class LutModel { Karis, HeightCorrelated, Multiscatter };
const char* lut_model_name(LutModel m);
LutModel lut_model_from_name(const std::string& name);  // throws std::invalid_argument

struct LutQuality {
    int phi_points = 4;   // Gauss-Legendre nodes per azimuth panel
    int u_points = 6;     // Gauss-Legendre nodes per theta_h panel
    // 0: integrate every texel. k >= 4: integrate k NdotV nodes per row and
    // interpolate between them (bake_brdf_lut), k times fewer integrals than
    // texels across.
    int row_nodes = 64;
};

struct LutValue { double a, b; };

// A and B at one (NdotV, r). Deterministic quadrature over the half vector:
// with u GGX's CDF variable, D cos(theta_h) dh = du dphi / 2pi and the
// integrand is G (v.h) / (NdotV cos theta_h) times (1 - Fc) or Fc. n.l
// changes sign at theta_h = psi/2 + pi/4 with psi = atan2(sin_v cos(phi),
// cos_v): the theta_h integral stops exactly there, so the integrand has no
// kink. In theta_h: a head panel [0, min(alpha, theta_max)] in t = sqrt(u),
// then panels growing 4x in theta_h (D's poles sit at +-i alpha), merged with
// panels graded toward theta_max down to the width of the layer where G falls
// to 0 (thin at grazing angles, for height-correlated Smith above all).
// Azimuth panels are graded toward phi = pi/2, where the limit swings from
// pi/2 to 0 over a width of about NdotV at grazing angles.
//   karis:              Schlick-GGX G, k = alpha / 2 (the seed shader, UE4)
//   height-correlated:  Smith G2 = 1 / (1 + Lambda(v) + Lambda(l))
//   multiscatter:       height-correlated, with Turquin 2019's energy
//                       compensation written linearly in F0: A' = 1 - B,
//                       B' = B (exact at F0 = 0 and F0 = 1, so F0 = 1 is a
//                       white furnace).
LutValue integrate_brdf(double ndotv, double roughness, LutModel model, const LutQuality& q = {});

// N x N LUT: texel (i, j), j from the top: NdotV = (i + .5)/N, r = (j + .5)/N.
// Red = A, green = B, blue = 0.
// With q.row_nodes = k (4 <= k < N), each row integrates k nodes spread
// uniformly in log(NdotV + alpha/50), alpha = r^2, from the first texel
// centre to the last, and fills its texels from a not-a-knot cubic spline in
// that variable; every row stays exact in roughness. The logarithm resolves
// the grazing end, where G turns on (at NdotV ~ alpha/2 for Schlick-GGX,
// more steeply for height-correlated Smith at high roughness), and the
// shift keeps the nodes off NdotV = 0 for rough rows. Measured at 512 against
// high-order LUTs: k = 64 adds nothing visible to the quadrature's 2.7e-5
// (Karis and height-correlated), k = 12 at low order gives about 1e-2.
Image bake_brdf_lut(int size, LutModel model, const LutQuality& q = {});

}  // namespace iblbake
