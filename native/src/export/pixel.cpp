#include "iblbake/export/pixel.h"

#include <Imath/half.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace iblbake {

namespace {

void put32(uint8_t* p, uint32_t v) {
    for (int k = 0; k < 4; ++k) p[k] = uint8_t(v >> (8 * k));
}
void put16(uint8_t* p, uint16_t v) {
    p[0] = uint8_t(v);
    p[1] = uint8_t(v >> 8);
}

// A non-negative finite value, NaN and negatives to 0.
float clean(float v) { return v > 0.0f ? v : 0.0f; }

// Unsigned float with a 5-bit exponent (bias 15) and `mbits` mantissa bits
// (EXT_packed_float's 11- and 10-bit floats), rounded to nearest even and
// clamped to the largest finite value.
uint32_t pack_ufloat(float v, int mbits) {
    if (!(v > 0.0f)) return 0;
    const uint32_t mmax = (1u << mbits) - 1, emax = 30;
    const double largest = (2.0 - std::ldexp(1.0, -mbits)) * 32768.0;
    if (!(double(v) < largest)) return (emax << mbits) | mmax;
    int e = 0;
    std::frexp(double(v), &e);  // v = f 2^e, f in [0.5, 1): v = 1.m 2^(e - 1)
    int biased = e - 1 + 15;
    if (biased <= 0) {  // denormal: v = m / 2^mbits * 2^-14
        const double m = std::nearbyint(std::ldexp(double(v), 14 + mbits));
        return uint32_t(m);  // m == 2^mbits is the smallest normal, encoded alike
    }
    double m = std::nearbyint((std::ldexp(double(v), -(e - 1)) - 1.0) * double(1u << mbits));
    if (m >= double(1u << mbits)) {
        m = 0.0;
        ++biased;
    }
    if (biased > int(emax)) return (emax << mbits) | mmax;
    return (uint32_t(biased) << mbits) | uint32_t(m);
}

float unpack_ufloat(uint32_t bits, int mbits) {
    const uint32_t e = bits >> mbits, m = bits & ((1u << mbits) - 1);
    if (e == 0) return float(std::ldexp(double(m), -14 - mbits));
    if (e == 31) return m ? std::nanf("") : INFINITY;
    return float(std::ldexp(1.0 + double(m) / double(1u << mbits), int(e) - 15));
}

}  // namespace

size_t texel_bytes(PixelFormat f) {
    switch (f) {
        case PixelFormat::Rgba16f: return 8;
        case PixelFormat::Rgba32f: return 16;
        case PixelFormat::E5b9g9r9:
        case PixelFormat::R11g11b10f: return 4;
        default: throw std::invalid_argument(std::string("no texel layout for format ") + pixel_format_name(f));
    }
}

float format_max(PixelFormat f) {
    switch (f) {
        case PixelFormat::Rgba16f: return 65504.0f;
        case PixelFormat::E5b9g9r9: return 65408.0f;    // 511/512 * 2^16
        case PixelFormat::R11g11b10f: return 65024.0f;  // red and green (11-bit); blue (10-bit): 64512
        case PixelFormat::RgbdPng: return 255.0f;
        default: return 3.4028235e38f;
    }
}

float half_to_float(uint16_t h) {
    Imath::half x;
    x.setBits(h);
    return float(x);
}

uint32_t pack_e5b9g9r9(float r, float g, float b) {
    // EXT_texture_shared_exponent with N = 9, B = 15, in exact double
    // arithmetic: floor(log2(maxc)) from the float's exponent field, the
    // scales 2^-(exp - B - N) from a table.
    constexpr int N = 9, B = 15;
    static const auto inv_scale = [] {
        std::array<double, 34> t{};
        for (int e = 0; e < 34; ++e) t[e] = std::ldexp(1.0, B + N - e);
        return t;
    }();
    const float maxv = 65408.0f;
    const float rc = std::min(clean(r), maxv), gc = std::min(clean(g), maxv), bc = std::min(clean(b), maxv);
    const float maxc = std::max({rc, gc, bc});
    uint32_t bits;
    std::memcpy(&bits, &maxc, 4);
    // Zero and denormals (below 2^-126) sit under 2^-16: the smallest exponent.
    const int floor_log2 = std::max(-B - 1, int((bits >> 23) & 0xff) - 127);
    int exp_shared = floor_log2 + 1 + B;
    if (uint32_t(double(maxc) * inv_scale[exp_shared] + 0.5) == (1u << N)) ++exp_shared;
    const double s = inv_scale[exp_shared];
    auto mant = [&](float c) { return uint32_t(double(c) * s + 0.5); };
    return mant(rc) | (mant(gc) << 9) | (mant(bc) << 18) | (uint32_t(exp_shared) << 27);
}

void unpack_e5b9g9r9(uint32_t v, float out[3]) {
    const int e = int(v >> 27) - 15 - 9;
    for (int c = 0; c < 3; ++c) out[c] = float(std::ldexp(double((v >> (9 * c)) & 511u), e));
}

uint32_t pack_r11g11b10f(float r, float g, float b) {
    return pack_ufloat(r, 6) | (pack_ufloat(g, 6) << 11) | (pack_ufloat(b, 5) << 22);
}

void unpack_r11g11b10f(uint32_t v, float out[3]) {
    out[0] = unpack_ufloat(v & 0x7ffu, 6);
    out[1] = unpack_ufloat((v >> 11) & 0x7ffu, 6);
    out[2] = unpack_ufloat(v >> 22, 5);
}

void pack_texels(const float* rgb, size_t count, PixelFormat f, uint8_t* out, PackStats& stats, std::ptrdiff_t step) {
    const size_t tb = texel_bytes(f);
    const float maxv = format_max(f);
    const float maxb = f == PixelFormat::R11g11b10f ? 64512.0f : maxv;
    // RGBA16F: the cleaned, clamped values are gathered a block at a time and
    // converted to half together (F16C where the CPU has it).
    constexpr size_t kBlock = 256;
    float rgba[4 * kBlock];
    uint16_t halves[4 * kBlock];
    size_t in_block = 0;
    uint8_t* block_out = out;
    auto flush = [&] {
        floats_to_half(rgba, halves, 4 * in_block);
        for (size_t k = 0; k < 4 * in_block; ++k) put16(block_out + 2 * k, halves[k]);
        in_block = 0;
    };
    for (size_t t = 0; t < count; ++t, rgb += step, out += tb) {
        float v[3];
        bool clamped = false;
        for (int c = 0; c < 3; ++c) {
            v[c] = clean(rgb[c]);
            stats.largest = std::max(stats.largest, v[c]);
            const float m = c == 2 ? maxb : maxv;
            if (v[c] > m) {
                v[c] = m;
                clamped = true;
            }
        }
        stats.clamped += clamped;
        switch (f) {
            case PixelFormat::Rgba16f: {
                if (in_block == 0) block_out = out;
                float* px = rgba + 4 * in_block;
                px[0] = v[0], px[1] = v[1], px[2] = v[2], px[3] = 1.0f;
                if (++in_block == kBlock) flush();
                break;
            }
            case PixelFormat::Rgba32f: {
                const float px[4] = {v[0], v[1], v[2], 1.0f};
                std::memcpy(out, px, 16);  // little-endian hosts (x86-64, arm64)
                break;
            }
            case PixelFormat::E5b9g9r9: put32(out, pack_e5b9g9r9(v[0], v[1], v[2])); break;
            case PixelFormat::R11g11b10f: put32(out, pack_r11g11b10f(v[0], v[1], v[2])); break;
            default: break;
        }
    }
    if (in_block) flush();
}

}  // namespace iblbake
