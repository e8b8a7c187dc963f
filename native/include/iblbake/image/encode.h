// Display encodings for PNG outputs (pure functions, no I/O).
#pragma once
#include <vector>

#include "iblbake/image/image.h"

namespace iblbake {

// All functions take and return interleaved RGBA buffers (cross_to_hcross_rgba).

// sRGB 8-bit, clamped, after scaling by 2^exposure; alpha kept.
std::vector<float> encode_srgb(const std::vector<float>& rgba, float exposure);

// RGBM: linear * 2^exposure = rgb * m * range, m quantised up to 1/255 so
// rgb <= 1. Unused cross cells (alpha 0) stay 0.
std::vector<float> encode_rgbm(const std::vector<float>& rgba, float exposure, float range);

// The same two, in place on `values` RGBA values (a band of a cross).
void encode_srgb_in_place(float* rgba, size_t values, float exposure);
void encode_rgbm_in_place(float* rgba, size_t values, float exposure, float range);

// Whether any value is beyond half float's range (65504) or not finite: for
// RGB or RGBA buffers alike (alpha is 0 or 1).
bool exceeds_half(FloatSpan values);

}  // namespace iblbake
