// KTX 2.0 cube maps (KTX 2.0 specification; Khronos Data Format 1.3 for the
// DFD), laid out as KTX-Software's writer2.c lays them out.
#include <zstd.h>

#include <algorithm>
#include <cstring>
#include <numeric>
#include <stdexcept>

#include "iblbake/export/container.h"

namespace iblbake {

namespace {

constexpr uint8_t kIdentifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
constexpr uint32_t kFloatMinusOne = 0xBF800000u, kFloatOne = 0x3F800000u;

void put32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
    for (int k = 0; k < 4; ++k) b[at + k] = uint8_t(v >> (8 * k));
}
void put64(std::vector<uint8_t>& b, size_t at, uint64_t v) {
    for (int k = 0; k < 8; ++k) b[at + k] = uint8_t(v >> (8 * k));
}
size_t align_up(size_t v, size_t a) { return (v + a - 1) / a * a; }

uint32_t sample_word0(uint32_t bit_offset, uint32_t bit_length, uint32_t channel) {
    return bit_offset | ((bit_length - 1) << 16) | (channel << 24);
}

// The level's texels: faces +X .. -Z, rows top to bottom, at `out`.
void pack_level(const Cubemap& cube, Mirror m, PixelFormat f, uint8_t* out, PackStats& stats) {
    const size_t face_bytes = size_t(cube.size) * cube.size * texel_bytes(f);
    for (int face = 0; face < 6; ++face) pack_face(cube, m, face, f, out + face * face_bytes, stats);
}
size_t level_size(const Cubemap& cube, PixelFormat f) { return size_t(6) * cube.size * cube.size * texel_bytes(f); }

}  // namespace

uint32_t ktx2_vk_format(PixelFormat f) {
    switch (f) {
        case PixelFormat::Rgba16f: return 97;    // VK_FORMAT_R16G16B16A16_SFLOAT
        case PixelFormat::Rgba32f: return 109;   // VK_FORMAT_R32G32B32A32_SFLOAT
        case PixelFormat::E5b9g9r9: return 123;  // VK_FORMAT_E5B9G9R9_UFLOAT_PACK32
        case PixelFormat::R11g11b10f: return 122;  // VK_FORMAT_B10G11R11_UFLOAT_PACK32
        default: throw std::invalid_argument(std::string("KTX2 takes no ") + pixel_format_name(f));
    }
}

std::vector<uint32_t> ktx2_basic_dfd(PixelFormat f) {
    // (bit offset, bit length, channel | qualifiers, lower, upper) per sample.
    struct Sample {
        uint32_t offset, length, channel, lower, upper;
    };
    std::vector<Sample> samples;
    constexpr uint32_t kFloat = 0x80, kSigned = 0x40, kExponent = 0x20;
    constexpr uint32_t kR = 0, kG = 1, kB = 2, kA = 15;
    switch (f) {
        case PixelFormat::Rgba16f:
        case PixelFormat::Rgba32f: {
            const uint32_t bits = f == PixelFormat::Rgba16f ? 16 : 32;
            uint32_t k = 0;
            for (uint32_t ch : {kR, kG, kB, kA})
                samples.push_back({bits * k++, bits, ch | kFloat | kSigned, kFloatMinusOne, kFloatOne});
            break;
        }
        case PixelFormat::E5b9g9r9:
            // Mantissas 9 bits at 0, 9, 18; the shared exponent (5 bits at
            // 27) once per channel; bounds as KTX-Software's createDFDPacked.
            for (uint32_t ch : {kR, kG, kB}) {
                samples.push_back({9 * ch, 9, ch, 0, 8448});
                samples.push_back({27, 5, ch | kExponent, 15, 31});
            }
            break;
        case PixelFormat::R11g11b10f:
            samples.push_back({0, 11, kR | kFloat, 0, kFloatOne});
            samples.push_back({11, 11, kG | kFloat, 0, kFloatOne});
            samples.push_back({22, 10, kB | kFloat, 0, kFloatOne});
            break;
        default: throw std::invalid_argument(std::string("KTX2 takes no ") + pixel_format_name(f));
    }
    const uint32_t block = 24 + 16 * uint32_t(samples.size());
    std::vector<uint32_t> d;
    d.push_back(4 + block);          // dfdTotalSize
    d.push_back(0);                  // vendorId 0 (Khronos), descriptorType 0 (basic)
    d.push_back(2 | (block << 16));  // versionNumber 2 (1.3), descriptorBlockSize
    d.push_back(1 | (1 << 8) | (1 << 16));  // model RGBSDA, primaries BT709, transfer linear, flags 0 (straight alpha)
    d.push_back(0);                         // texel block 1 x 1 x 1 x 1
    d.push_back(uint32_t(texel_bytes(f)));  // bytesPlane0
    d.push_back(0);                         // bytesPlane4..7
    for (const Sample& s : samples) {
        d.push_back(sample_word0(s.offset, s.length, s.channel));
        d.push_back(0);  // sample position
        d.push_back(s.lower);
        d.push_back(s.upper);
    }
    return d;
}

Encoded encode_ktx2(const CubeChain& chain, const EncodeOptions& o) {
    check_chain(chain);
    const uint32_t vk = ktx2_vk_format(o.format);
    const size_t tb = texel_bytes(o.format);
    const uint32_t levels = uint32_t(chain.levels.size());
    const uint32_t n0 = uint32_t(chain.levels[0]->size);
    Encoded e;

    // Supercompressed levels are made first (their lengths set the layout);
    // uncompressed ones are packed straight into the file below.
    std::vector<size_t> raw_size(levels), stored_size(levels);
    std::vector<std::vector<uint8_t>> stored(levels);
    std::vector<uint8_t> raw;
    for (uint32_t m = 0; m < levels; ++m) {
        raw_size[m] = stored_size[m] = level_size(*chain.levels[m], o.format);
        if (o.zstd) {
            raw.resize(raw_size[m]);
            pack_level(*chain.levels[m], chain.mirror, o.format, raw.data(), e.stats);
            stored[m].resize(ZSTD_compressBound(raw.size()));
            const size_t got = ZSTD_compress(stored[m].data(), stored[m].size(), raw.data(), raw.size(), o.zstd_level);
            if (ZSTD_isError(got)) throw std::runtime_error(std::string("zstd: ") + ZSTD_getErrorName(got));
            stored[m].resize(got);
            stored_size[m] = got;
        }
    }

    // Key/value data, sorted by key (KTX2 requires it), each entry padded to 4.
    std::vector<std::pair<std::string, std::string>> kv = o.key_values;
    kv.emplace_back("KTXorientation", std::string("rd") + '\0');
    kv.emplace_back("KTXwriter", (o.writer.empty() ? std::string("iblbake") : o.writer) + '\0');
    std::sort(kv.begin(), kv.end());
    std::vector<uint8_t> kvd;
    for (const auto& [key, value] : kv) {
        const uint32_t len = uint32_t(key.size() + 1 + value.size());
        const size_t at = kvd.size();
        kvd.resize(align_up(at + 4 + len, 4), 0);
        put32(kvd, at, len);
        std::memcpy(kvd.data() + at + 4, key.c_str(), key.size() + 1);
        std::memcpy(kvd.data() + at + 4 + key.size() + 1, value.data(), value.size());
    }

    const std::vector<uint32_t> dfd = ktx2_basic_dfd(o.format);
    const size_t index_at = 80, dfd_at = index_at + 24 * size_t(levels), dfd_len = dfd.size() * 4;
    const size_t kvd_at = dfd_at + dfd_len;
    // Levels aligned to lcm(texel size, 4), or 1 when supercompressed.
    const size_t align = o.zstd ? 1 : std::lcm(tb, size_t(4));
    // Data smallest level first (the base level last).
    std::vector<size_t> offset(levels);
    size_t at = kvd_at + kvd.size();
    for (int m = int(levels) - 1; m >= 0; --m) {
        at = align_up(at, align);
        offset[m] = at;
        at += stored_size[m];
    }
    std::vector<uint8_t>& b = e.bytes;
    b.assign(at, 0);
    std::memcpy(b.data(), kIdentifier, 12);
    const uint32_t header[9] = {vk, o.format == PixelFormat::Rgba16f ? 2u : 4u, n0, n0, 0, 0, 6, levels,
                                o.zstd ? 2u : 0u};
    for (int k = 0; k < 9; ++k) put32(b, 12 + 4 * k, header[k]);
    put32(b, 48, uint32_t(dfd_at));
    put32(b, 52, uint32_t(dfd_len));
    put32(b, 56, uint32_t(kvd_at));
    put32(b, 60, uint32_t(kvd.size()));
    put64(b, 64, 0);  // no supercompression global data
    put64(b, 72, 0);
    for (uint32_t m = 0; m < levels; ++m) {  // the index: level 0 first
        put64(b, index_at + 24 * m, offset[m]);
        put64(b, index_at + 24 * m + 8, stored_size[m]);
        put64(b, index_at + 24 * m + 16, raw_size[m]);
    }
    for (size_t k = 0; k < dfd.size(); ++k) put32(b, dfd_at + 4 * k, dfd[k]);
    std::copy(kvd.begin(), kvd.end(), b.begin() + kvd_at);
    for (uint32_t m = 0; m < levels; ++m) {
        if (o.zstd) std::copy(stored[m].begin(), stored[m].end(), b.begin() + offset[m]);
        else pack_level(*chain.levels[m], chain.mirror, o.format, b.data() + offset[m], e.stats);
    }
    return e;
}

}  // namespace iblbake
