#include "exr_zip.h"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace iblbake::io::detail {

void undo_zip_predictor_scalar(uint8_t* b, size_t n) {
    for (size_t i = 1; i < n; ++i) b[i] = uint8_t(int(b[i - 1]) + int(b[i]) - 128);
}

#if defined(__x86_64__)

namespace {

bool has_avx2() {
    static const bool yes = __builtin_cpu_supports("avx2");
    return yes;
}

// As undo_zip_predictor_sse2 below, 32 bytes at a time: the prefix sums within
// each 16-byte lane, then the low lane's last sum added to the high lane,
// then the byte before them.
__attribute__((target("avx2"))) void undo_zip_predictor_avx2(uint8_t* b, size_t n) {
    const __m256i bias = _mm256_set1_epi8(char(0x80)), last = _mm256_set1_epi8(15);
    __m256i carry = _mm256_set1_epi8(char(b[0]));
    size_t i = 1;
    for (; i + 32 <= n; i += 32) {
        __m256i v = _mm256_sub_epi8(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(b + i)), bias);
        v = _mm256_add_epi8(v, _mm256_slli_si256(v, 1));
        v = _mm256_add_epi8(v, _mm256_slli_si256(v, 2));
        v = _mm256_add_epi8(v, _mm256_slli_si256(v, 4));
        v = _mm256_add_epi8(v, _mm256_slli_si256(v, 8));
        const __m256i low_sum = _mm256_shuffle_epi8(v, last);                       // each lane's byte 15
        v = _mm256_add_epi8(v, _mm256_permute2x128_si256(low_sum, low_sum, 0x08));  // (0, the low lane's)
        v = _mm256_add_epi8(v, carry);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(b + i), v);
        const __m256i lanes = _mm256_shuffle_epi8(v, last);
        carry = _mm256_permute2x128_si256(lanes, lanes, 0x11);  // byte 31 everywhere
    }
    undo_zip_predictor_scalar(b + i - 1, n - i + 1);
}

}  // namespace

// 16 bytes d at a time (d = b - 128): their prefix sums within the vector by
// adding the vector shifted by 1, 2, 4 and 8 bytes, then the byte before them
// (the last one written) to each. Byte arithmetic wraps as the definition's
// mod 256 does, so every byte is the scalar loop's.
void undo_zip_predictor_sse2(uint8_t* b, size_t n) {
    if (n < 2) return;
    const __m128i bias = _mm_set1_epi8(char(0x80));
    __m128i carry = _mm_set1_epi8(char(b[0]));
    size_t i = 1;
    for (; i + 16 <= n; i += 16) {
        __m128i v = _mm_sub_epi8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(b + i)), bias);
        v = _mm_add_epi8(v, _mm_slli_si128(v, 1));
        v = _mm_add_epi8(v, _mm_slli_si128(v, 2));
        v = _mm_add_epi8(v, _mm_slli_si128(v, 4));
        v = _mm_add_epi8(v, _mm_slli_si128(v, 8));
        v = _mm_add_epi8(v, carry);
        _mm_storeu_si128(reinterpret_cast<__m128i*>(b + i), v);
        // Byte 15 to every byte (SSE2: no byte shuffle).
        const __m128i t = _mm_shufflehi_epi16(_mm_unpackhi_epi8(v, v), 0xFF);
        carry = _mm_unpackhi_epi64(t, t);
    }
    undo_zip_predictor_scalar(b + i - 1, n - i + 1);
}

void undo_zip_predictor(uint8_t* b, size_t n) {
    if (n < 2) return;
    if (has_avx2())
        undo_zip_predictor_avx2(b, n);
    else
        undo_zip_predictor_sse2(b, n);
}

#else

void undo_zip_predictor(uint8_t* b, size_t n) { undo_zip_predictor_scalar(b, n); }

#endif

namespace {

// A channel's values in one line of a split block: low bytes at lo[x], high
// bytes at hi[x].
struct Plane {
    const uint8_t* lo;
    const uint8_t* hi;
};

Plane split_plane(const uint8_t* block, size_t size, const HalfPlanes& p, int line, int c) {
    const size_t at = (size_t(line) * p.line_bytes + p.plane[c]) / 2;
    return {block + at, block + (size + 1) / 2 + at};
}

void split_line_scalar(const Plane (&pl)[3], int from, int width, uint16_t* out) {
    for (int x = from; x < width; ++x)
        for (int c = 0; c < 3; ++c) out[size_t(x) * 3 + c] = uint16_t(pl[c].lo[x] | (pl[c].hi[x] << 8));
}

#if defined(__x86_64__)

// The pshufb masks that place 8 halves of one channel into the three
// vectors of 24 interleaved halves: output half o = 8 v + j is channel o % 3
// of pixel o / 3.
struct InterleaveMasks {
    alignas(16) uint8_t m[3][3][16];  // [output vector][channel][byte]
    InterleaveMasks() {
        for (int v = 0; v < 3; ++v)
            for (int c = 0; c < 3; ++c)
                for (int j = 0; j < 8; ++j) {
                    const int o = 8 * v + j;
                    const bool mine = o % 3 == c;
                    m[v][c][2 * j] = mine ? uint8_t(2 * (o / 3)) : 0x80;
                    m[v][c][2 * j + 1] = mine ? uint8_t(2 * (o / 3) + 1) : 0x80;
                }
    }
};
const InterleaveMasks kMasks;

__attribute__((target("ssse3"))) inline void interleave8(__m128i r, __m128i g, __m128i b, uint16_t* out) {
    for (int v = 0; v < 3; ++v) {
        const __m128i* m = reinterpret_cast<const __m128i*>(kMasks.m[v]);
        const __m128i o = _mm_or_si128(_mm_or_si128(_mm_shuffle_epi8(r, _mm_load_si128(m)),
                                                    _mm_shuffle_epi8(g, _mm_load_si128(m + 1))),
                                       _mm_shuffle_epi8(b, _mm_load_si128(m + 2)));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(out + 8 * v), o);
    }
}

// 16 pixels at a time: each channel's 16 low and 16 high bytes made halves
// (unpack), then interleaved 8 pixels at a time.
__attribute__((target("ssse3"))) void split_line_ssse3(const Plane (&pl)[3], int width, uint16_t* out) {
    int x = 0;
    for (; x + 16 <= width; x += 16) {
        __m128i h[3][2];
        for (int c = 0; c < 3; ++c) {
            const __m128i lo = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pl[c].lo + x));
            const __m128i hi = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pl[c].hi + x));
            h[c][0] = _mm_unpacklo_epi8(lo, hi);
            h[c][1] = _mm_unpackhi_epi8(lo, hi);
        }
        interleave8(h[0][0], h[1][0], h[2][0], out + size_t(x) * 3);
        interleave8(h[0][1], h[1][1], h[2][1], out + size_t(x) * 3 + 24);
    }
    split_line_scalar(pl, x, width, out);
}

bool has_ssse3() {
    static const bool yes = __builtin_cpu_supports("ssse3");
    return yes;
}

#endif

// Each line's three planes to `line(planes, out_line)`.
template <typename LineFn>
void split_lines(const uint8_t* block, size_t size, const HalfPlanes& p, int width, int first, int lines,
                 uint16_t* out, LineFn line) {
    for (int l = 0; l < lines; ++l) {
        const Plane pl[3] = {split_plane(block, size, p, first + l, 0), split_plane(block, size, p, first + l, 1),
                             split_plane(block, size, p, first + l, 2)};
        line(pl, out + size_t(l) * size_t(width) * 3);
    }
}

}  // namespace

void split_block_to_rgb_scalar(const uint8_t* block, size_t size, const HalfPlanes& p, int width, int first, int lines,
                               uint16_t* out) {
    split_lines(block, size, p, width, first, lines, out,
                [width](const Plane(&pl)[3], uint16_t* o) { split_line_scalar(pl, 0, width, o); });
}

void split_block_to_rgb(const uint8_t* block, size_t size, const HalfPlanes& p, int width, int first, int lines,
                        uint16_t* out) {
#if defined(__x86_64__)
    if (has_ssse3()) {
        split_lines(block, size, p, width, first, lines, out,
                    [width](const Plane(&pl)[3], uint16_t* o) { split_line_ssse3(pl, width, o); });
        return;
    }
#endif
    split_block_to_rgb_scalar(block, size, p, width, first, lines, out);
}

void plain_block_to_rgb(const uint8_t* block, const HalfPlanes& p, int width, int first, int lines, uint16_t* out) {
    for (int l = 0; l < lines; ++l) {
        const uint8_t* line = block + size_t(first + l) * p.line_bytes;
        uint16_t* o = out + size_t(l) * size_t(width) * 3;
        for (int x = 0; x < width; ++x)
            for (int c = 0; c < 3; ++c) {
                const uint8_t* v = line + p.plane[c] + 2 * size_t(x);
                o[size_t(x) * 3 + c] = uint16_t(v[0] | (v[1] << 8));
            }
    }
}

}  // namespace iblbake::io::detail
