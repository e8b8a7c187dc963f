// Diffuse irradiance (SPEC.md section 3), stored divided by pi:
//   Irr(n) = (1/pi) integral L(w) max(0, n.w) dw.
#pragma once
#include <vector>

#include "iblbake/ibl/source.h"
#include "iblbake/image/image.h"

namespace iblbake {

// Exact cosine convolution of a vector cloud (ibl/source.h) and of the hot
// texels' points: every output texel sums (1/pi) max(0, n.V_c) over the
// cloud, so the result is the exact integral except for the reduced bins
// that straddle n's horizon. A hot point is a texel's hat (SPEC's bilinear
// L), small but bright: one that straddles n's horizon (|n.m| < 5 sigma,
// sigma^2 = n^T C n) gives P E[max(0, X)] with X = n.w Gaussian of the hat's
// mean and variance, mu Phi(mu / sigma) + sigma phi(mu / sigma), instead of
// P max(0, mu). Faces larger than `exact_face_limit` are evaluated at that
// size and resampled bilinearly (Irr is smooth: its curvature is that of a
// clamped cosine).
void irradiance_convolve(Cubemap& dst, const VectorCloud& cloud, const std::vector<RadiancePoint>& hot,
                         int exact_face_limit = 64);

}  // namespace iblbake
