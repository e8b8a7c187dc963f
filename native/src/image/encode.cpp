#include "iblbake/image/encode.h"

#include <algorithm>
#include <cmath>

#include "iblbake/math/color.h"

namespace iblbake {

std::vector<float> encode_srgb(const Image& img, const std::vector<float>& alpha, float exposure) {
    const size_t count = size_t(img.width) * img.height;
    const float scale = std::exp2(exposure);
    std::vector<float> out(count * 4);
    for (size_t p = 0; p < count; ++p) {
        for (int k = 0; k < 3; ++k) out[p * 4 + k] = linear_to_srgb(img.pixels[p * 3 + k] * scale);
        out[p * 4 + 3] = alpha.empty() ? 1.0f : alpha[p];
    }
    return out;
}

std::vector<float> encode_rgbm(const Image& img, const std::vector<float>& alpha, float exposure, float range) {
    const size_t count = size_t(img.width) * img.height;
    const float scale = std::exp2(exposure) / range;
    std::vector<float> out(count * 4, 0.0f);
    for (size_t p = 0; p < count; ++p) {
        if (!alpha.empty() && alpha[p] == 0.0f) continue;
        float c[3];
        for (int k = 0; k < 3; ++k) c[k] = std::max(0.0f, img.pixels[p * 3 + k] * scale);
        float m = std::clamp(std::max(c[0], std::max(c[1], c[2])), 1.0f / 255.0f, 1.0f);
        m = std::ceil(m * 255.0f) / 255.0f;
        for (int k = 0; k < 3; ++k) out[p * 4 + k] = std::min(1.0f, c[k] / m);
        out[p * 4 + 3] = m;
    }
    return out;
}

float max_value(const Image& img) {
    float m = 0.0f;
    for (float v : img.pixels)
        if (std::isfinite(v)) m = std::max(m, std::fabs(v));
    return m;
}

}  // namespace iblbake
