// PNG files through libpng: 8 or 16 bits, grey, RGB or RGBA; values arrive
// already encoded (8-bit: sRGB or RGBM; 16-bit: linear, marked gAMA 1).
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <vector>

#include "raw_pixels.h"

namespace iblbake::io::detail {

void write_png_file_rows(const std::string& path, int width, int height, int channels, int bits,
                         const std::function<void(int y0, int rows, float* out)>& fill, int level) {
    std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
    if (!f) throw std::runtime_error("cannot open for writing");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        throw std::runtime_error("libpng could not start");
    }
    const int stride = width * channels * (bits / 8);
    std::vector<unsigned char> row(stride);
    // Bands of 64 rows from `fill`: no whole-image buffer.
    const int band = std::min(64, height);
    std::vector<float> values(size_t(width) * channels * band);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        throw std::runtime_error("libpng failed");
    }
    png_init_io(png, f.get());
    png_set_compression_level(png, level);
    if (level <= 2) png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);  // one filter: no per-row search
    static const int kTypes[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                  PNG_COLOR_TYPE_RGB_ALPHA};
    png_set_IHDR(png, info, width, height, bits, kTypes[channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    if (bits == 16) png_set_gAMA(png, info, 1.0);  // 16-bit files hold linear data (the LUT)
    png_write_info(png, info);
    const float scale = bits == 8 ? 255.0f : 65535.0f;
    for (int y = 0; y < height; ++y) {
        if (y % band == 0) fill(y, std::min(band, height - y), values.data());
        const float* src = values.data() + size_t(y % band) * width * channels;
        for (int k = 0; k < width * channels; ++k) {
            const float v = std::fmin(std::fmax(src[k], 0.0f), 1.0f);
            const unsigned q = unsigned(std::lround(v * scale));
            if (bits == 8) {
                row[k] = static_cast<unsigned char>(q);
            } else {  // big-endian
                row[2 * k] = static_cast<unsigned char>(q >> 8);
                row[2 * k + 1] = static_cast<unsigned char>(q & 0xff);
            }
        }
        png_write_row(png, row.data());
    }
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
}

namespace {
void append_to_vector(png_structp png, png_bytep data, png_size_t length) {
    auto* out = static_cast<std::vector<unsigned char>*>(png_get_io_ptr(png));
    out->insert(out->end(), data, data + length);
}
void flush_nothing(png_structp) {}
}  // namespace

std::vector<unsigned char> encode_png8_memory(int width, int height, int channels, const unsigned char* values,
                                              int level) {
    std::vector<unsigned char> out;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        throw std::runtime_error("libpng could not start");
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        throw std::runtime_error("libpng failed");
    }
    png_set_write_fn(png, &out, &append_to_vector, &flush_nothing);
    png_set_compression_level(png, level);
    if (level <= 2) png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);  // one filter: no per-row search
    static const int kTypes[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                  PNG_COLOR_TYPE_RGB_ALPHA};
    png_set_IHDR(png, info, width, height, 8, kTypes[channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < height; ++y)
        png_write_row(png, const_cast<png_bytep>(values + size_t(y) * width * channels));
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return out;
}

}  // namespace iblbake::io::detail
