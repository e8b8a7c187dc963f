// GGX / Trowbridge-Reitz distribution and Smith masking (Walter et al. 2007,
// "Microfacet Models for Refraction through Rough Surfaces"; Karis 2013,
// "Real Shading in Unreal Engine 4"; Heitz 2014, "Understanding the
// Masking-Shadowing Function in Microfacet-Based BRDFs"). alpha = r^2 for
// perceptual roughness r (SPEC.md section 3). No I/O.
//
// Sampling follows pbrt's threes: a sample function that takes its uniform
// number as an argument, its pdf, and its inverse.
#pragma once
#include <cmath>

#include "iblbake/math/vec3.h"

namespace iblbake::ggx {

// D(h) from cos^2 and sin^2 of theta_h (passing sin^2 keeps precision near the
// peak where 1 - cos^2 cancels): D = a^2 / (pi (sin^2 + a^2 cos^2)^2).
inline double D(double alpha, double cos2, double sin2) {
    const double a2 = alpha * alpha;
    const double t = sin2 + a2 * cos2;
    return a2 / (kPi * t * t);
}

// The "CDF variable" u in [0, 1): the h distribution D(h) cos(theta_h) sampled
// by u gives cos^2(theta_h) = (1 - u) / (1 + (a^2 - 1) u).
inline double sample_cos2(double alpha, double u) {
    const double a2 = alpha * alpha;
    return (1.0 - u) / (1.0 + (a2 - 1.0) * u);
}
inline double sample_sin2(double alpha, double u) {
    const double a2 = alpha * alpha;
    return a2 * u / (1.0 + (a2 - 1.0) * u);
}
// pdf of h (solid angle measure) for that sampling: D(h) cos(theta_h).
inline double pdf_h(double alpha, double cos2, double sin2) { return D(alpha, cos2, sin2) * std::sqrt(cos2); }
// Inverse: the u that gives cos^2(theta_h) = cos2.
inline double invert_sample(double alpha, double cos2, double sin2) {
    const double a2 = alpha * alpha;
    return sin2 / (sin2 + a2 * cos2);
}

// The prefilter kernel of SPEC.md section 3 with N = V = R = n, as a function
// of one_minus_c = 1 - n.w (pass |n - w|^2 / 2 for precision):
//   K = D(h) max(0, n.w), n.h = sqrt((1 + n.w) / 2).
inline double prefilter_kernel(double alpha, double one_minus_c) {
    const double c = 1.0 - one_minus_c;
    if (c <= 0.0) return 0.0;
    const double a2 = alpha * alpha;
    const double t = one_minus_c + a2 * (1.0 + c);  // 2 (sin^2 + a^2 cos^2)
    return 4.0 * a2 / (kPi * t * t) * c;
}

// The same kernel in float up to its constant factor 4 a^2 / pi (which
// cancels in self-normalised sums), for the hot loops: a2 = alpha^2,
// one_minus_c = |n - w|^2 / 2.
inline float prefilter_kernel_shape(float a2, float one_minus_c) {
    const float c = 1.0f - one_minus_c;
    const float t = one_minus_c + a2 * (1.0f + c);
    return c > 0.0f ? c / (t * t) : 0.0f;
}

// Z(alpha) = integral over the sphere of the prefilter kernel,
// = 4 * integral_0^{1/(1+a^2)} (1 - (a^2+1) u) / (1 + (a^2-1) u) du.
// Closed form 4 [ -1/c + 2a^2/c^2 ln(2a^2/(1+a^2)) ], c = a^2 - 1; near
// alpha = 1 (c -> 0) the integrand is smooth and Gauss-Legendre takes over.
double prefilter_normalizer(double alpha);

// Smith masking-shadowing, the LUT models.
// Schlick-GGX with k = alpha / 2 (UE4, the seed shader): G1 = x / (x (1 - k) + k).
inline double g1_schlick(double ndotx, double k) { return ndotx / (ndotx * (1.0 - k) + k); }
// Smith Lambda for GGX: (-1 + sqrt(1 + a^2 tan^2)) / 2.
inline double smith_lambda(double ndotx, double alpha) {
    const double c2 = ndotx * ndotx;
    const double t2 = std::fmax(0.0, 1.0 - c2) / c2;
    return 0.5 * (std::sqrt(1.0 + alpha * alpha * t2) - 1.0);
}
// Height-correlated Smith G2 = 1 / (1 + Lambda(v) + Lambda(l)).
inline double g2_height_correlated(double ndotv, double ndotl, double alpha) {
    return 1.0 / (1.0 + smith_lambda(ndotv, alpha) + smith_lambda(ndotl, alpha));
}

}  // namespace iblbake::ggx
