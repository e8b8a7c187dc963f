// Source files written by hand for the readers' tests: formats iblbake
// reads through OpenImageIO's plugin but never writes (Radiance HDR, PFM),
// so that what the plugin hands back is checked against another writer.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include "iblbake/image/image.h"

namespace iblbake::testfiles {

// A Radiance RGBE file with flat (uncompressed) scanlines, top row first
// under the resolution line `resolution` ("-Y H +X W" is the usual order; the
// line is written as given, so "+Y H +X W" makes a file stored bottom-up).
// No scanline starts with the bytes 2 2 that mark a run-length one.
inline void write_radiance(const std::string& path, const Image& img, const std::string& resolution) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return;
    std::fprintf(f, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n%s\n", resolution.c_str());
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const float* p = img.at(x, y);
            const float m = std::max({p[0], p[1], p[2]});
            unsigned char rgbe[4] = {0, 0, 0, 0};
            if (m > 1e-32f) {
                int e = 0;
                const float scale = std::frexp(m, &e) * 256.0f / m;
                for (int k = 0; k < 3; ++k) rgbe[k] = (unsigned char)std::clamp(p[k] * scale, 0.0f, 255.0f);
                rgbe[3] = (unsigned char)(e + 128);
            }
            if (x == 0 && rgbe[0] == 2 && rgbe[1] == 2) rgbe[1] = 3;
            std::fwrite(rgbe, 1, 4, f);
        }
    std::fclose(f);
}

// A colour PFM (little-endian floats, stored bottom row first as the format says).
inline void write_pfm(const std::string& path, const Image& img) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return;
    std::fprintf(f, "PF\n%d %d\n-1.0\n", img.width, img.height);
    for (int y = img.height - 1; y >= 0; --y) std::fwrite(img.at(0, y), sizeof(float), size_t(img.width) * 3, f);
    std::fclose(f);
}

}  // namespace iblbake::testfiles
