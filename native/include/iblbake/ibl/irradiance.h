// Diffuse irradiance (SPEC.md section 3), stored divided by pi:
//   Irr(n) = (1/pi) integral L(w) max(0, n.w) dw.
#pragma once
#include <vector>

#include "iblbake/ibl/source.h"
#include "iblbake/image/image.h"

namespace iblbake {

// The exact bins of a bw x bh lat-long grid (ibl/source.h) in 2 x 2 groups,
// for the cosine convolution: per channel each bin's vector power
// V = integral L w dOmega, and each group's sum of them with the group's
// centre direction and angular radius.
struct BinGroups {
    int count = 0;
    std::vector<float> cx, cy, cz, sin_radius;  // per group; sin_radius 2: always summed bin by bin
    std::vector<float> vx[3], vy[3], vz[3];       // per group, per channel: the sum of its bins' V
    std::vector<float> bx[3], by[3], bz[3];       // per bin, four per group (missing bins zero)
    // Bins brighter than `bright` x the mean bin's power, taken out of the
    // above and kept as points, one per channel (mean direction V_c / P_c,
    // the covariance of w about it): irradiance_convolve treats them as the
    // hot texels (issue 25: a low sun's aureole across a texel's horizon).
    std::vector<RadiancePoint> points;
};
BinGroups group_bins(const std::vector<Bin>& bins, int bw, int bh, double bright = 16.0);

// Exact cosine convolution of the bins and of the hot texels' points: every
// output texel sums (1/pi) max(0, n.V_c) over the bins, the exact integral
// except for bins that straddle n's horizon. A group wholly on n's lit side
// adds n.V of its sum at once and one wholly behind nothing (the same sum in
// a quarter of the work); only groups across n's horizon go bin by bin. A
// hot point is a texel's hat (SPEC's bilinear L), small but bright: one that
// straddles n's horizon (|n.m| < 5 sigma, sigma^2 = n^T C n) gives
// P E[max(0, X)] with X = n.w Gaussian of the hat's mean and variance,
// mu Phi(mu / sigma) + sigma phi(mu / sigma), instead of P max(0, mu).
// Faces larger than `exact_face_limit` are evaluated at that size and
// resampled bilinearly (Irr is smooth: its curvature is that of a clamped
// cosine).
void irradiance_convolve(Cubemap& dst, const BinGroups& bins, const std::vector<RadiancePoint>& hot,
                         int exact_face_limit = 64);

// H(x) = phi(x) - x Phi(-x) for x in [0, 5] (phi, Phi: the standard normal
// density and distribution), within 1e-16 or so: E[max(0, X)] - max(0, mu) =
// sigma H(|mu| / sigma) for X Gaussian (mu, sigma^2), the hot points'
// correction across a texel's horizon, without erfc or exp.
double horizon_excess(double x);

}  // namespace iblbake
