// Diffuse irradiance (SPEC.md section 3), stored divided by pi:
//   Irr(n) = (1/pi) integral L(w) max(0, n.w) dw.
#pragma once
#include "iblbake/ibl/source.h"
#include "iblbake/image/image.h"

namespace iblbake {

// Exact cosine convolution of a vector cloud (ibl/source.h): every output
// texel sums (1/pi) max(0, n.V_c) over the cloud, so the result is the exact
// integral except for the reduced bins that straddle n's horizon. Faces
// larger than `exact_face_limit` are evaluated at that size and resampled
// bilinearly (Irr is smooth: its curvature is that of a clamped cosine).
void irradiance_convolve(Cubemap& dst, const VectorCloud& cloud, int exact_face_limit = 64);

}  // namespace iblbake
