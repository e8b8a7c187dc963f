// Source files written by hand for the readers' tests: formats iblbake
// reads but never writes (Radiance HDR, PFM, JPEG, interlaced PNG), so that
// what the readers hand back is checked against another writer.
#pragma once
#include <png.h>
// jpeglib.h needs size_t and FILE declared first.
#include <cstddef>
#include <cstdio>
#include <jpeglib.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "iblbake/image/image.h"

namespace iblbake::testfiles {

// A Radiance RGBE file with flat (uncompressed) scanlines, top row first
// under the resolution line `resolution` ("-Y H +X W" is the usual order; the
// line is written as given, so "+Y H +X W" makes a file stored bottom-up).
// No scanline starts with the bytes 2 2 that mark a run-length one.
inline void write_radiance(const std::string& path, const Image& img, const std::string& resolution) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return;
    std::fprintf(f, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n%s\n", resolution.c_str());
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const float* p = img.at(x, y);
            const float m = std::max({p[0], p[1], p[2]});
            unsigned char rgbe[4] = {0, 0, 0, 0};
            if (m > 1e-32f) {
                int e = 0;
                const float scale = std::frexp(m, &e) * 256.0f / m;
                for (int k = 0; k < 3; ++k) rgbe[k] = (unsigned char)std::clamp(p[k] * scale, 0.0f, 255.0f);
                rgbe[3] = (unsigned char)(e + 128);
            }
            if (x == 0 && rgbe[0] == 2 && rgbe[1] == 2) rgbe[1] = 3;
            std::fwrite(rgbe, 1, 4, f);
        }
    std::fclose(f);
}

// A colour PFM (little-endian floats, stored bottom row first as the format says).
inline void write_pfm(const std::string& path, const Image& img) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return;
    std::fprintf(f, "PF\n%d %d\n-1.0\n", img.width, img.height);
    for (int y = img.height - 1; y >= 0; --y) std::fwrite(img.at(0, y), sizeof(float), size_t(img.width) * 3, f);
    std::fclose(f);
}

// A baseline JPEG (libjpeg, quality 95) of the image's values clamped to [0, 1] (as sRGB bytes), RGB or grey.
inline void write_jpeg(const std::string& path, const Image& img, bool grey = false) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return;
    jpeg_compress_struct c{};
    jpeg_error_mgr err{};
    c.err = jpeg_std_error(&err);
    jpeg_create_compress(&c);
    jpeg_stdio_dest(&c, f);
    c.image_width = JDIMENSION(img.width);
    c.image_height = JDIMENSION(img.height);
    c.input_components = grey ? 1 : 3;
    c.in_color_space = grey ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, 95, TRUE);
    jpeg_start_compress(&c, TRUE);
    std::vector<unsigned char> row(size_t(img.width) * 3);
    while (c.next_scanline < c.image_height) {
        const float* p = img.at(0, int(c.next_scanline));
        for (int x = 0; x < img.width * c.input_components; ++x)
            row[x] = (unsigned char)std::lround(255.0f * std::clamp(p[grey ? x * 3 : x], 0.0f, 1.0f));
        JSAMPROW r = row.data();
        jpeg_write_scanlines(&c, &r, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    std::fclose(f);
}

// An interlaced (Adam7) 8-bit RGB PNG of the image's values clamped to [0, 1].
inline void write_png_interlaced(const std::string& path, const Image& img) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        std::fclose(f);
        return;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, png_uint_32(img.width), png_uint_32(img.height), 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_ADAM7, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    std::vector<unsigned char> bytes(size_t(img.width) * img.height * 3);
    for (size_t k = 0; k < bytes.size(); ++k)
        bytes[k] = (unsigned char)std::lround(255.0f * std::clamp(img.pixels[k], 0.0f, 1.0f));
    std::vector<png_bytep> rows(size_t(img.height));
    for (int y = 0; y < img.height; ++y) rows[y] = bytes.data() + size_t(y) * img.width * 3;
    png_write_image(png, rows.data());
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
}

}  // namespace iblbake::testfiles
