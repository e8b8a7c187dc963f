// Display encodings for PNG outputs (pure functions, no I/O).
#pragma once
#include <vector>

#include "iblbake/image/image.h"

namespace iblbake {

// sRGB 8-bit, clamped, after scaling by 2^exposure. Output is RGBA in [0, 1],
// alpha from `alpha` (1 where it is empty).
std::vector<float> encode_srgb(const Image& img, const std::vector<float>& alpha, float exposure);

// RGBM: linear * 2^exposure = rgb * m * range, m quantised up to 1/255 so
// rgb <= 1. Output RGBA in [0, 1]; unused cross cells (alpha 0) are 0.
std::vector<float> encode_rgbm(const Image& img, const std::vector<float>& alpha, float exposure, float range);

// Largest finite value (for the half-float overflow check).
float max_value(const Image& img);

}  // namespace iblbake
