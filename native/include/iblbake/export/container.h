// Container encoders: one file each (ktx2.cpp, dds.cpp, ktx1.cpp, env.cpp),
// one interface. Each takes a cube's mip chain (already in the engine's
// convention: mirrored, at the preset's roughness per level) and returns the
// file's bytes. None knows another; none does I/O.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "iblbake/export/convert.h"
#include "iblbake/export/pixel.h"
#include "iblbake/export/preset.h"
#include "iblbake/image/image.h"

namespace iblbake {

// Level 0 first; level m has face max(1, N0 >> m); faces in SPEC order. The
// mirror is applied as the texels are packed (no copy of the cubes).
struct CubeChain {
    std::vector<const Cubemap*> levels;
    Mirror mirror = Mirror::None;
};
// Face `face` of a level as the container stores it (the chain's mirror
// applied; rows top to bottom), packed in format f: size^2 texels at `out`.
void pack_face(const Cubemap& cube, Mirror m, int face, PixelFormat f, uint8_t* out, PackStats& stats);

struct EncodeOptions {
    PixelFormat format = PixelFormat::Rgba16f;
    bool zstd = false;    // KTX2: Zstandard supercompression of every level
    int zstd_level = 2;
    std::string writer;   // KTX2 KTXwriter
    // Key/value metadata (KTX1: Filament's `sh`), written in this order.
    std::vector<std::pair<std::string, std::string>> key_values;
    // .env: the irradiance polynomial and the lod scale of the header.
    std::optional<Polynomial> polynomial;
    double lod_generation_scale = 0.8;
};

struct Encoded {
    std::vector<uint8_t> bytes;
    PackStats stats;  // texels clamped to the format's range, largest value
};

Encoded encode_ktx2(const CubeChain& chain, const EncodeOptions& o);
Encoded encode_dds(const CubeChain& chain, const EncodeOptions& o);
Encoded encode_ktx1(const CubeChain& chain, const EncodeOptions& o);
Encoded encode_env(const CubeChain& chain, const EncodeOptions& o);

using Encoder = Encoded (*)(const CubeChain&, const EncodeOptions&);
// The encoder of a cube container (not Container::Source).
Encoder encoder_for(Container c);

// Checks a chain: at least one level, level m of face max(1, N0 >> m).
// Throws std::invalid_argument.
void check_chain(const CubeChain& chain);

// KTX2's Basic Data Format Descriptor for a format, as KTX-Software writes it
// (the dfdTotalSize word first). Exposed for tests.
std::vector<uint32_t> ktx2_basic_dfd(PixelFormat f);
uint32_t ktx2_vk_format(PixelFormat f);

// Babylon's RGBD (helperFunctions toRGBD, gamma 2.2) of one linear colour, as
// the bytes its PNG holds; and the decode Babylon applies.
void rgbd_encode(const float rgb[3], uint8_t out[4]);
void rgbd_decode(const uint8_t in[4], float rgb[3]);

}  // namespace iblbake
