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

namespace iblbake {

namespace {
constexpr uint8_t kMagic[8] = {0x86, 0x16, 0x87, 0x96, 0xF6, 0xD6, 0x96, 0x36};
}

// toRGBD in float, as the shader computes it, then stored as
// round(clamp(v) * 255) as DumpDataAsync does.
void rgbd_encode(const float rgb[3], uint8_t out[4]) {
    float c[3];
    for (int k = 0; k < 3; ++k) c[k] = rgb[k] > 0.0f ? rgb[k] : 0.0f;  // NaN and negatives to 0
    const float max_rgb = std::max(std::max(c[0], std::max(c[1], c[2])), 1e-7f);
    float d = std::max(255.0f / max_rgb, 1.0f);
    d = std::clamp(std::floor(d) / 255.0f, 0.0f, 1.0f);
    for (int k = 0; k < 3; ++k) {
        const float g = std::pow(c[k] * d, 1.0f / 2.2f);
        out[k] = uint8_t(std::lround(std::clamp(g, 0.0f, 1.0f) * 255.0f));
    }
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
    std::vector<std::vector<uint8_t>> images;
    std::vector<uint8_t> rgba;
    for (const Cubemap* c : chain.levels) {
        const size_t texels = size_t(c->size) * c->size;
        rgba.resize(texels * 4);
        for (int face = 0; face < 6; ++face) {
            const float* src = c->pixels.data() + size_t(face) * texels * 3;
            for (size_t t = 0; t < texels; ++t) {
                const float* v = src + 3 * t;
                const float m = std::max({v[0], v[1], v[2]});
                e.stats.largest = std::max(e.stats.largest, m);
                e.stats.clamped += m > 255.0f;
                // Babylon stores each face bottom row first (its own writer and loader
                // do; tests/engines/engine_babylon.mjs measures it): row j goes to size - 1 - j.
                const size_t row = size_t(c->size) - 1 - t / size_t(c->size), col = t % size_t(c->size);
                rgbd_encode(v, rgba.data() + 4 * (row * size_t(c->size) + col));
            }
            images.push_back(io::encode_png8(c->size, c->size, 4, rgba.data()));
        }
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
