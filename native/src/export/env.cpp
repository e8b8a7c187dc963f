// Babylon.js .env (version 2) as @babylonjs/core's environmentTextureTools
// writes and reads it: magic, a NUL-terminated JSON header, then one RGBD PNG
// per face and level, level-major.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "iblbake/export/container.h"
#include "iblbake/io/image_io.h"
#include "iblbake/util/parallel.h"

namespace iblbake {

namespace {
constexpr uint8_t kMagic[8] = {0x86, 0x16, 0x87, 0x96, 0xF6, 0xD6, 0x96, 0x36};
}

namespace {
// 8-bit gamma encoding round(255 v^(1/2.2)) of v in [0, 1], exactly and
// without pow: a table over the float's exponent and top 10 mantissa bits
// gives the byte at the start of v's interval, and one comparison with the
// next rounding threshold ((k + 1/2) / 255)^2.2 finishes it (an interval is
// narrower than the gap between two thresholds).
class GammaBytes {
public:
    GammaBytes() : table_(kEntries) {
        for (int k = 0; k < 255; ++k) next_[k] = float(std::pow((k + 0.5) / 255.0, 2.2));
        next_[255] = 2.0f;  // never reached for v <= 1
        for (uint32_t i = 0; i < kEntries; ++i) {
            const uint32_t bits = (i + kFirst) << 13;
            float v;
            std::memcpy(&v, &bits, 4);
            table_[i] = slow(v);
        }
    }
    uint8_t operator()(float v) const {
        uint32_t bits;
        std::memcpy(&bits, &v, 4);
        if (!(v > 0.0f)) return 0;
        const uint32_t key = bits >> 13;
        if (key < kFirst) return 0;  // below 2^-20: under the first threshold (1.1e-6)
        if (key >= kFirst + kEntries) return 255;
        uint8_t b = table_[key - kFirst];
        while (b < 255 && v >= next_[b]) ++b;
        return b;
    }

private:
    static constexpr uint32_t kFirst = (127u - 20u) << 10, kEntries = (21u << 10) + 1;
    uint8_t slow(float v) const {  // the number of thresholds <= v
        return uint8_t(std::upper_bound(next_, next_ + 255, v) - next_);
    }
    float next_[256];
    std::vector<uint8_t> table_;
};
// Made on first use (a Babylon export), not when any program that links
// this starts.
const GammaBytes& gamma_bytes() {
    static const GammaBytes table;
    return table;
}
}  // namespace

// toRGBD as the shader computes it (D from the largest channel, gamma 2.2),
// stored as round(clamp(v) * 255) as DumpDataAsync does; the gamma rounding
// is exact (thresholds) where the GPU's pow rounds within a byte's width.
void rgbd_encode(const float rgb[3], uint8_t out[4]) {
    float c[3];
    for (int k = 0; k < 3; ++k) c[k] = rgb[k] > 0.0f ? rgb[k] : 0.0f;  // NaN and negatives to 0
    const float max_rgb = std::max(std::max(c[0], std::max(c[1], c[2])), 1e-7f);
    float d = std::max(255.0f / max_rgb, 1.0f);
    d = std::clamp(std::floor(d) / 255.0f, 0.0f, 1.0f);
    const GammaBytes& gamma = gamma_bytes();
    for (int k = 0; k < 3; ++k) out[k] = gamma(std::min(c[k] * d, 1.0f));
    out[3] = uint8_t(std::lround(d * 255.0f));
}

void rgbd_decode(const uint8_t in[4], float rgb[3]) {
    const float d = in[3] / 255.0f;
    for (int k = 0; k < 3; ++k) rgb[k] = std::pow(in[k] / 255.0f, 2.2f) / d;
}

Encoded encode_env(const CubeChain& chain, const EncodeOptions& o) {
    check_chain(chain);
    const int n0 = chain.levels[0]->size;
    if (n0 & (n0 - 1)) throw std::invalid_argument("a Babylon .env needs a power-of-two face size, not " +
                                                   std::to_string(n0));
    int full = 1;
    while ((n0 >> (full - 1)) > 1) ++full;
    if (int(chain.levels.size()) != full)
        throw std::invalid_argument("a Babylon .env needs every level down to 1 x 1 (" + std::to_string(full) +
                                    " for face " + std::to_string(n0) + "), got " +
                                    std::to_string(chain.levels.size()));
    if (!o.polynomial) throw std::invalid_argument("a Babylon .env needs its irradiance polynomial");
    Encoded e;
    // Every face of every level is its own PNG: encoded side by side.
    const int faces = 6 * int(chain.levels.size());
    std::vector<std::vector<uint8_t>> images(faces);
    std::vector<PackStats> stats(faces);
    parallel_for(0, faces, [&](int k) {
        const Cubemap* c = chain.levels[k / 6];
        const int face = k % 6;
        std::vector<uint8_t> rgba(size_t(c->size) * c->size * 4);
        PackStats& st = stats[k];
        for (int j = 0; j < c->size; ++j) {
            const RowSource row = mirrored_row(*c, chain.mirror, face, j);
            // Babylon stores each face bottom row first (its own writer and
            // loader do; the engine tests measure it): row j is PNG row n - 1 - j.
            uint8_t* out = rgba.data() + 4 * size_t(c->size - 1 - j) * c->size;
            for (int i = 0; i < c->size; ++i) {
                const float* v = row.first + i * row.step;
                const float m = std::max({v[0], v[1], v[2]});
                st.largest = std::max(st.largest, m);
                st.clamped += m > 255.0f;
                rgbd_encode(v, out + 4 * i);
            }
        }
        images[k] = io::encode_png8(c->size, c->size, 4, rgba.data());
    });
    for (const PackStats& st : stats) {
        e.stats.largest = std::max(e.stats.largest, st.largest);
        e.stats.clamped += st.clamped;
    }
    const Polynomial& p = *o.polynomial;
    auto vec = [](const std::array<double, 3>& v) { return nlohmann::json::array({v[0], v[1], v[2]}); };
    nlohmann::ordered_json info;
    info["version"] = 2;
    info["width"] = n0;
    info["imageType"] = "image/png";
    info["irradiance"] = {{"x", vec(p.x)},   {"y", vec(p.y)},   {"z", vec(p.z)},
                          {"xx", vec(p.xx)}, {"yy", vec(p.yy)}, {"zz", vec(p.zz)},
                          {"yz", vec(p.yz)}, {"zx", vec(p.zx)}, {"xy", vec(p.xy)}};
    nlohmann::ordered_json mipmaps = nlohmann::ordered_json::array();
    size_t position = 0;
    for (const auto& img : images) {
        mipmaps.push_back({{"length", img.size()}, {"position", position}});
        position += img.size();
    }
    info["specular"] = {{"mipmaps", mipmaps}, {"lodGenerationScale", o.lod_generation_scale}};
    const std::string header = info.dump();  // ASCII: numbers and plain keys
    std::vector<uint8_t>& b = e.bytes;
    b.assign(8 + header.size() + 1 + position, 0);
    std::memcpy(b.data(), kMagic, 8);
    std::memcpy(b.data() + 8, header.data(), header.size());  // then the NUL, already there
    size_t at = 8 + header.size() + 1;
    for (const auto& img : images) {
        std::memcpy(b.data() + at, img.data(), img.size());
        at += img.size();
    }
    return e;
}

}  // namespace iblbake
