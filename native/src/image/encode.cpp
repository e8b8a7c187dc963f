#include "iblbake/image/encode.h"

#include <algorithm>
#include <cmath>

#include "iblbake/math/color.h"

namespace iblbake {

void encode_srgb_in_place(float* rgba, size_t values, float exposure) {
    const float scale = std::exp2(exposure);
    for (size_t p = 0; p < values; p += 4)
        for (int k = 0; k < 3; ++k) rgba[p + k] = linear_to_srgb(rgba[p + k] * scale);
}

void encode_rgbm_in_place(float* rgba, size_t values, float exposure, float range) {
    const float scale = std::exp2(exposure) / range;
    for (size_t p = 0; p < values; p += 4) {
        if (rgba[p + 3] == 0.0f) {
            rgba[p] = rgba[p + 1] = rgba[p + 2] = 0.0f;
            continue;
        }
        float c[3];
        for (int k = 0; k < 3; ++k) c[k] = std::max(0.0f, rgba[p + k] * scale);
        float m = std::clamp(std::max(c[0], std::max(c[1], c[2])), 1.0f / 255.0f, 1.0f);
        m = std::ceil(m * 255.0f) / 255.0f;
        for (int k = 0; k < 3; ++k) rgba[p + k] = std::min(1.0f, c[k] / m);
        rgba[p + 3] = m;
    }
}

std::vector<float> encode_srgb(const std::vector<float>& rgba, float exposure) {
    std::vector<float> out = rgba;
    encode_srgb_in_place(out.data(), out.size(), exposure);
    return out;
}

std::vector<float> encode_rgbm(const std::vector<float>& rgba, float exposure, float range) {
    std::vector<float> out = rgba;
    encode_rgbm_in_place(out.data(), out.size(), exposure, range);
    return out;
}

bool exceeds_half(FloatSpan values) { return any_beyond(values, 65504.0f); }

}  // namespace iblbake
