// DirectDraw Surface cube maps with the DX10 header (Microsoft's "DDS
// Programming Guide": DDS_HEADER, DDS_PIXELFORMAT, DDS_HEADER_DXT10).
#include <cstring>
#include <stdexcept>

#include "iblbake/export/container.h"

namespace iblbake {

namespace {

void put32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = uint8_t(v >> (8 * k));
}

constexpr uint32_t kCaps = 0x1, kHeight = 0x2, kWidth = 0x4, kPitch = 0x8, kPixelFormat = 0x1000,
                   kMipMapCount = 0x20000;
constexpr uint32_t kCapsComplex = 0x8, kCapsTexture = 0x1000, kCapsMipMap = 0x400000;
constexpr uint32_t kCaps2Cubemap = 0x200, kCaps2AllFaces = 0xFC00;  // +X -X +Y -Y +Z -Z
constexpr uint32_t kPfFourCC = 0x4;

uint32_t dxgi_format(PixelFormat f) {
    switch (f) {
        case PixelFormat::Rgba16f: return 10;  // DXGI_FORMAT_R16G16B16A16_FLOAT
        case PixelFormat::Rgba32f: return 2;   // DXGI_FORMAT_R32G32B32A32_FLOAT
        default: throw std::invalid_argument(std::string("DDS takes no ") + pixel_format_name(f));
    }
}

}  // namespace

Encoded encode_dds(const CubeChain& chain, const EncodeOptions& o) {
    check_chain(chain);
    const uint32_t dxgi = dxgi_format(o.format);
    const size_t tb = texel_bytes(o.format);
    const uint32_t n0 = uint32_t(chain.levels[0]->size), levels = uint32_t(chain.levels.size());
    size_t data = 0;
    for (const Cubemap* c : chain.levels) data += size_t(6) * c->size * c->size * tb;
    Encoded e;
    std::vector<uint8_t>& b = e.bytes;
    b.assign(4 + 124 + 20 + data, 0);
    std::memcpy(b.data(), "DDS ", 4);
    // DDS_HEADER at 4.
    put32(b, 4, 124);
    put32(b, 8, kCaps | kHeight | kWidth | kPitch | kPixelFormat | kMipMapCount);
    put32(b, 12, n0);                  // height
    put32(b, 16, n0);                  // width
    put32(b, 20, uint32_t(n0 * tb));   // pitch of a base level row
    put32(b, 24, 0);                   // depth
    put32(b, 28, levels);              // mip map count
    // dwReserved1[11] stays 0. DDS_PIXELFORMAT at 76.
    put32(b, 76, 32);
    put32(b, 80, kPfFourCC);
    std::memcpy(b.data() + 84, "DX10", 4);
    put32(b, 108, kCapsComplex | kCapsTexture | kCapsMipMap);
    put32(b, 112, kCaps2Cubemap | kCaps2AllFaces);
    // DDS_HEADER_DXT10 at 128.
    put32(b, 128, dxgi);
    put32(b, 132, 3);    // D3D10_RESOURCE_DIMENSION_TEXTURE2D
    put32(b, 136, 0x4);  // DDS_RESOURCE_MISC_TEXTURECUBE
    put32(b, 140, 1);    // one cube
    put32(b, 144, 0);    // alpha mode unknown
    // Face-major: each face with its whole mip chain.
    size_t at = 148;
    for (int face = 0; face < 6; ++face)
        for (const Cubemap* c : chain.levels) {
            pack_face(*c, chain.mirror, face, o.format, b.data() + at, e.stats);
            at += size_t(c->size) * c->size * tb;
        }
    return e;
}

}  // namespace iblbake
