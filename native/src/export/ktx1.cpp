// KTX 1.1 cube maps as Filament reads them (libs/image Ktx1Bundle, libs/ktxreader
// Ktx1Reader): the KTX 1.1 layout, key/value pairs (Filament's `sh`).
#include <cstring>
#include <stdexcept>

#include "iblbake/export/container.h"

namespace iblbake {

namespace {

constexpr uint8_t kIdentifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x31, 0x31, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};

void append32(std::vector<uint8_t>& b, uint32_t v) {
    for (int k = 0; k < 4; ++k) b.push_back(uint8_t(v >> (8 * k)));
}
void append(std::vector<uint8_t>& b, const void* data, size_t n) {
    const size_t at = b.size();
    b.resize(at + n);
    if (n) std::memcpy(b.data() + at, data, n);
}

struct GlFormat {
    uint32_t type, type_size, format, internal_format, base_internal_format;
};

GlFormat gl_format(PixelFormat f) {
    switch (f) {
        case PixelFormat::Rgba16f: return {0x140B, 2, 0x1908, 0x881A, 0x1908};  // HALF_FLOAT, RGBA, RGBA16F
        case PixelFormat::Rgba32f: return {0x1406, 4, 0x1908, 0x8814, 0x1908};  // FLOAT, RGBA, RGBA32F
        // R11F_G11F_B10F: glType 0x8C3A as Filament's Ktx1Reader expects it
        // (and cmgen writes it), not GL's UNSIGNED_INT_10F_11F_11F_REV 0x8C3B.
        case PixelFormat::R11g11b10f: return {0x8C3A, 4, 0x1907, 0x8C3A, 0x1907};
        default: throw std::invalid_argument(std::string("KTX1 takes no ") + pixel_format_name(f));
    }
}

}  // namespace

Encoded encode_ktx1(const CubeChain& chain, const EncodeOptions& o) {
    check_chain(chain);
    const GlFormat gl = gl_format(o.format);
    const size_t tb = texel_bytes(o.format);
    const uint32_t n0 = uint32_t(chain.levels[0]->size), levels = uint32_t(chain.levels.size());
    std::vector<uint8_t> kvd;
    for (const auto& [key, value] : o.key_values) {
        const uint32_t len = uint32_t(key.size() + 1 + value.size());
        append32(kvd, len);
        append(kvd, key.c_str(), key.size() + 1);
        append(kvd, value.data(), value.size());
        while (kvd.size() % 4) kvd.push_back(0);  // valuePadding
    }
    Encoded e;
    std::vector<uint8_t>& b = e.bytes;
    append(b, kIdentifier, 12);
    for (uint32_t v : {0x04030201u, gl.type, gl.type_size, gl.format, gl.internal_format, gl.base_internal_format,
                       n0, n0, 0u /* depth */, 0u /* array elements */, 6u /* faces */, levels,
                       uint32_t(kvd.size())})
        append32(b, v);
    append(b, kvd.data(), kvd.size());
    for (const Cubemap* c : chain.levels) {
        const size_t texels = size_t(c->size) * c->size, face_bytes = texels * tb;  // rows are whole words
        append32(b, uint32_t(face_bytes));  // imageSize: one face of a non-array cube
        const size_t at = b.size();
        b.resize(at + 6 * face_bytes);
        for (int face = 0; face < 6; ++face)
            pack_face(*c, chain.mirror, face, o.format, b.data() + at + face * face_bytes, e.stats);
    }
    return e;
}

}  // namespace iblbake
