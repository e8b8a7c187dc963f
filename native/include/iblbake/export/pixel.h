// GPU pixel formats of the exported containers: RGB float texels to bytes
// (little-endian), and back for tests. Pure functions, no I/O.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "iblbake/export/preset.h"
#include "iblbake/math/half.h"

namespace iblbake {

// Bytes of one texel: RGBA16F 8, RGBA32F 16, E5B9G9R9 and R11G11B10F 4.
size_t texel_bytes(PixelFormat f);

// Values a format cannot hold are clamped to its largest finite value (and
// counted); NaN and negative values (none reach here from a bake) become 0.
// Alpha, where the format has it, is 1.
struct PackStats {
    uint64_t clamped = 0;  // texels with a channel above the format's range
    float largest = 0.0f;  // the largest channel value seen
};
// `count` RGB texels -> count * texel_bytes(f) bytes at `out`; the texels are
// read `step` floats apart (3: contiguous, -3: backwards).
void pack_texels(const float* rgb, size_t count, PixelFormat f, uint8_t* out, PackStats& stats,
                 std::ptrdiff_t step = 3);

// The largest finite value of each format.
float format_max(PixelFormat f);

// Single values (exposed for tests).
// float_to_half (round to nearest even, IEEE binary16): iblbake/math/half.h
float half_to_float(uint16_t h);
uint32_t pack_e5b9g9r9(float r, float g, float b);  // EXT_texture_shared_exponent
void unpack_e5b9g9r9(uint32_t v, float out[3]);
uint32_t pack_r11g11b10f(float r, float g, float b);  // EXT_packed_float
void unpack_r11g11b10f(uint32_t v, float out[3]);

}  // namespace iblbake
