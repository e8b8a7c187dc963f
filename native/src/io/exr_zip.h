// OpenEXR's ZIP and ZIPS blocks of HALF channels, undone here rather than by
// OpenEXR (ExrRowReader's fast path, exr_file.cpp). Private to io/; pure byte
// transforms, no I/O.
//
// How OpenEXR stores a block (ImfZip.cpp, "Zip::compress"; the same in every
// version since 1.0): a block of scanlines is laid out line by line, each
// line holding every channel's values in turn (the header's channel order,
// little-endian); its bytes are split, even-indexed bytes first, then
// odd-indexed ones (for halves: every low byte, then every high byte); a
// predictor replaces each byte but the first by its difference from the one
// before, plus 128 (mod 256); zlib compresses the result. A block whose
// compressed form would not be smaller is stored as it is, unsplit.
//
// Why by hand: OpenEXR 3.1 (Debian 12's) undoes the predictor a byte at a
// time, a loop whose every step waits for the last (its SSE4.1 version is not
// in Debian's build), and then copies the halves through its line buffers;
// at 16K the loop alone was 18 % of the decode's CPU.
#pragma once
#include <cstddef>
#include <cstdint>

namespace iblbake::io::detail {

// Undoes the predictor in place: b[i] = b[i - 1] + b[i] - 128 (mod 256) for
// i >= 1, in order (a prefix sum of the bytes less 128). SSE2 or AVX2: 16 or
// 32 bytes at a time, the prefix within them by shifted adds.
void undo_zip_predictor(uint8_t* b, size_t n);
void undo_zip_predictor_scalar(uint8_t* b, size_t n);  // the definition, for the tests
#if defined(__x86_64__)
void undo_zip_predictor_sse2(uint8_t* b, size_t n);  // what a CPU without AVX2 runs, for the tests
#endif

// Where a block's R, G and B HALF channels lie: each line of the block is
// `line_bytes` long (every channel's `width` values in turn), and R, G, B
// start `plane[0]`, `plane[1]`, `plane[2]` bytes into it (even numbers: every
// channel's values are 2 or 4 bytes).
struct HalfPlanes {
    size_t line_bytes = 0;
    size_t plane[3] = {0, 0, 0};
};

// Lines first .. first + lines - 1 of a decompressed block of `size` bytes
// (predictor undone, still split: the low bytes from 0, the high ones from
// (size + 1) / 2) as halves, RGB interleaved, into out (lines x width x 3).
void split_block_to_rgb(const uint8_t* block, size_t size, const HalfPlanes& p, int width, int first, int lines,
                        uint16_t* out);
void split_block_to_rgb_scalar(const uint8_t* block, size_t size, const HalfPlanes& p, int width, int first,
                               int lines, uint16_t* out);  // the definition, for the tests

// The same from a block stored as it is (neither split nor predicted).
void plain_block_to_rgb(const uint8_t* block, const HalfPlanes& p, int width, int first, int lines, uint16_t* out);

}  // namespace iblbake::io::detail
