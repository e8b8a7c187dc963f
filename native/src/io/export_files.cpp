// The exported containers' files: raw bytes, Radiance HDR, in-memory PNG.
#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <stdexcept>

#include "iblbake/io/image_io.h"
#include "raw_pixels.h"

namespace iblbake::io {

namespace {
using File = std::unique_ptr<FILE, int (*)(FILE*)>;

// The reason (strerror) is part of every message: "No space left on device".
[[noreturn]] void cannot(const char* what, const std::string& path, const char* after = "") {
    const int e = errno;
    throw std::runtime_error(std::string(what) + " '" + path + "'" + after +
                             (e ? std::string(": ") + std::strerror(e) : ""));
}

File open_for_writing(const std::string& path) {
    errno = 0;
    File f(std::fopen(path.c_str(), "wb"), &std::fclose);
    if (!f) cannot("cannot open", path, " for writing");
    return f;
}

void write_all(FILE* f, const void* data, size_t bytes, const std::string& path) {
    errno = 0;
    if (bytes && std::fwrite(data, 1, bytes, f) != bytes) cannot("cannot write", path);
}

void flush(FILE* f, const std::string& path) {
    errno = 0;
    if (std::fflush(f) != 0) cannot("cannot write", path);
}
}  // namespace

std::vector<uint8_t> encode_png8(int width, int height, int channels, const uint8_t* values, int level) {
    if (width < 1 || height < 1 || channels < 1 || channels > 4 || level < 0 || level > 9)
        throw std::invalid_argument("encode_png8: bad image size, channel count or zlib level");
    return detail::encode_png8_memory(width, height, channels, values, level);
}

void write_png16_fast(const std::string& path, int width, int height, int channels, FloatSpan values) {
    if (values.size != size_t(width) * height * channels)
        throw std::invalid_argument("write_png16_fast: " + std::to_string(values.size) + " values for a " +
                                    std::to_string(width) + " x " + std::to_string(height) + " x " +
                                    std::to_string(channels) + " image");
    try {
        detail::write_png_file_rows(
            path, width, height, channels, 16,
            [&](int y0, int rows, float* out) {
                std::copy_n(values.data + size_t(y0) * width * channels, size_t(rows) * width * channels, out);
            },
            1);
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot write '" + path + "': " + e.what());
    }
}

bool float_to_rgbe(const float rgb[3], uint8_t out[4]) {
    // RGBE's largest value: mantissa 255 at exponent byte 255 (255 x 2^119,
    // about 1.69e38); above it the exponent byte would wrap to 0 (black).
    const float kLargest = std::ldexp(255.0f, 119);
    const float peak = std::fmax(rgb[0], std::fmax(rgb[1], rgb[2]));
    if (!(peak >= 1e-32f)) {
        out[0] = out[1] = out[2] = out[3] = 0;
        return false;
    }
    const bool clamped = peak > kLargest;
    const float v = clamped ? kLargest : peak;
    int e = 0;
    const float m = std::frexp(v, &e);  // v = m 2^e, m in [0.5, 1)
    const float scale = m * 256.0f / v * (v / peak);  // a clamped texel keeps its hue
    for (int c = 0; c < 3; ++c) out[c] = uint8_t(std::fmin(std::fmax(rgb[c], 0.0f) * scale, 255.0f));
    out[3] = uint8_t(e + 128);
    return clamped;
}

uint64_t write_hdr(const std::string& path, const Image& img) {
    uint64_t clamped = 0;
    if (img.width < 1 || img.height < 1) throw std::invalid_argument("write_hdr: empty image");
    File f = open_for_writing(path);
    const std::string header = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y " + std::to_string(img.height) + " +X " +
                               std::to_string(img.width) + "\n";
    write_all(f.get(), header.data(), header.size(), path);
    std::vector<uint8_t> row(size_t(img.width) * 4), rle;
    // Widths 8..32767 use the run-length scanline format (each component
    // as literal dumps of up to 128 bytes): a flat scanline whose first pixel
    // reads 2, 2, x < 128 would be taken for a run-length one by readers.
    const bool runs = img.width >= 8 && img.width <= 0x7fff;
    for (int y = 0; y < img.height; ++y) {
        for (int x = 0; x < img.width; ++x) clamped += float_to_rgbe(img.at(x, y), row.data() + size_t(x) * 4);
        if (!runs) {
            write_all(f.get(), row.data(), row.size(), path);
            continue;
        }
        rle = {2, 2, uint8_t(img.width >> 8), uint8_t(img.width & 0xff)};
        for (int c = 0; c < 4; ++c)
            for (int x0 = 0; x0 < img.width; x0 += 128) {
                const int n = std::min(128, img.width - x0);
                rle.push_back(uint8_t(n));
                for (int x = x0; x < x0 + n; ++x) rle.push_back(row[size_t(x) * 4 + c]);
            }
        write_all(f.get(), rle.data(), rle.size(), path);
    }
    flush(f.get(), path);
    return clamped;
}

namespace {

void write_file(const std::string& path, const void* data, size_t size) {
    File f = open_for_writing(path);
    write_all(f.get(), data, size, path);
    flush(f.get(), path);
}

}  // namespace

void write_bytes(const std::string& path, const std::vector<uint8_t>& bytes) { write_file(path, bytes.data(), bytes.size()); }

void write_text(const std::string& path, const std::string& text) { write_file(path, text.data(), text.size()); }

}  // namespace iblbake::io
