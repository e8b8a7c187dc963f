// All image file I/O. EXR through OpenEXR and PNG through libpng directly;
// other formats through OpenImageIO, in a plugin loaded only when such a file
// is read (src/io/oiio_plugin.cpp), so baking EXR starts in milliseconds.
// Nothing else in the library reads or writes image files.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "iblbake/image/image.h"

namespace iblbake::io {

struct LoadedImage {
    Image image;          // RGB, linear
    int source_channels;  // as stored in the file
    bool linearised;      // an integer sRGB file was converted to linear
    std::string format;   // OpenImageIO's format name ("openexr", "hdr", "png", ...)
};

// EXR, Radiance .hdr, PNG, JPEG (anything OpenImageIO reads). Grey is
// expanded, alpha dropped; integer (8/16-bit) files are treated as sRGB and
// linearised unless they declare a linear colour space. Throws
// std::runtime_error with a one-line reason on missing, empty or corrupt files.
LoadedImage read_image(const std::string& path);

enum class ExrPixel { Half, Float };
// Zip-compressed EXR from an interleaved buffer of 3 (RGB) or 4 (RGBA)
// channels. No time stamp, so equal pixels give equal files.
void write_exr(const std::string& path, int width, int height, int channels, const std::vector<float>& values,
               ExrPixel pixel);
inline void write_exr(const std::string& path, const Image& img, ExrPixel pixel) {
    write_exr(path, img.width, img.height, 3, img.pixels, pixel);
}
// The same, written in bands of rows that fill(y0, rows, out) supplies
// (rows * width * channels values), so no whole-image buffer is needed.
void write_exr_rows(const std::string& path, int width, int height, int channels, ExrPixel pixel,
                    const std::function<void(int y0, int rows, float* out)>& fill);
// 8-bit RGBA PNG from already-encoded values in [0, 1].
void write_png8(const std::string& path, int width, int height, int channels, const std::vector<float>& values);
// The same, written in bands of rows that fill(y0, rows, out) supplies.
void write_png8_rows(const std::string& path, int width, int height, int channels,
                     const std::function<void(int y0, int rows, float* out)>& fill);
// 16-bit PNG from values in [0, 1].
void write_png16(const std::string& path, int width, int height, int channels, const std::vector<float>& values);

// An 8-bit PNG's bytes in memory from width * height * channels bytes (rows
// top to bottom), with no gamma or colour chunk: the bytes are data (the
// RGBD faces of a Babylon .env).
// zlib level 1 by default: several times faster than 6, for about 20 % more bytes.
std::vector<uint8_t> encode_png8(int width, int height, int channels, const uint8_t* values, int level = 1);
// write_png16 at zlib level 1 (the exported LUTs).
void write_png16_fast(const std::string& path, int width, int height, int channels, const std::vector<float>& values);
// Radiance HDR (RGBE; run-length scanlines of literal dumps) from an RGB float image (rows top to bottom).
void write_hdr(const std::string& path, const Image& img);
// RGBE of one colour, as Ward's float2rgbe (exposed for tests).
void float_to_rgbe(const float rgb[3], uint8_t out[4]);
// A file of these bytes (exported containers).
void write_bytes(const std::string& path, const std::vector<uint8_t>& bytes);

}  // namespace iblbake::io
