// io: files in and out (images, hashes, atomic output folders, printable
// text). Above image/; beside ibl/, which it never includes: reading and
// writing know no integrator.
//
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
    int source_channels = 0;  // as stored in the file
    bool linearised = false;  // an integer sRGB file was converted to linear
    std::string format;   // OpenImageIO's format name ("openexr", "hdr", "png", ...)
    std::vector<std::string> warnings;  // what was odd but readable (a 2-channel file, a cropped window, ...)
};

// The largest source any reader (and bake()) accepts, checked before
// anything is allocated: at most kMaxSourceSide on a side and
// kMaxSourcePixels in all (32768 x 16384: 6.4 GB of RGB floats).
constexpr int64_t kMaxSourceSide = 65536;
constexpr int64_t kMaxSourcePixels = int64_t(32768) * 16384;
// A file must hold at least one byte per kMaxExpansion bytes of the float
// pixels its header declares (no codec of these formats packs more; a
// 500-byte header declaring gigabytes is refused before any allocation).
constexpr int64_t kMaxExpansion = 65536;
// Throws std::runtime_error (one line) when a width x height image is empty
// or larger than the maximum; `what` names it ("image", "display window").
void check_source_size(int64_t width, int64_t height, const std::string& what = "image");

// EXR, Radiance .hdr, PNG, JPEG, TIFF and the other formats OpenImageIO
// reads, the format told by the file's first bytes, else by its extension
// (no probing of every reader). Grey is expanded, alpha dropped; integer
// (8/16-bit) files are treated as sRGB and linearised unless they declare a
// linear colour space. Throws std::runtime_error with a one-line reason on
// missing, empty, non-regular (FIFO, device), truncated, corrupt or
// oversized files. An EXR's display window is baked when it holds the data
// window and is at most 4 times its size (outside the data is black),
// else the data window alone, with a warning.
LoadedImage read_image(const std::string& path);

// The format read_image takes `path` for ("openexr", "png", "jpeg", "hdr",
// "tiff", ...; "" when neither its first bytes nor its extension name one).
std::string image_format(const std::string& path);
// Whether this build reads that format: OpenEXR, PNG and JPEG always, the
// others when the OpenImageIO plugin loads (the wheels have none).
bool reads_format(const std::string& format);

enum class ExrPixel { Half, Float };
// Zip-compressed EXR from an interleaved buffer of 3 (RGB) or 4 (RGBA)
// channels. No time stamp, so equal pixels give equal files.
void write_exr(const std::string& path, int width, int height, int channels, FloatSpan values,
               ExrPixel pixel);
inline void write_exr(const std::string& path, const Image& img, ExrPixel pixel) {
    write_exr(path, img.width, img.height, 3, img.pixels, pixel);
}
// The same, written in bands of rows that fill(y0, rows, out) supplies
// (rows * width * channels values), so no whole-image buffer is needed.
void write_exr_rows(const std::string& path, int width, int height, int channels, ExrPixel pixel,
                    const std::function<void(int y0, int rows, float* out)>& fill);
// 8-bit RGBA PNG from already-encoded values in [0, 1].
void write_png8(const std::string& path, int width, int height, int channels, FloatSpan values);
// The same, written in bands of rows that fill(y0, rows, out) supplies.
void write_png8_rows(const std::string& path, int width, int height, int channels,
                     const std::function<void(int y0, int rows, float* out)>& fill);
// 16-bit PNG from values in [0, 1].
void write_png16(const std::string& path, int width, int height, int channels, FloatSpan values);

// An 8-bit PNG's bytes in memory from width * height * channels bytes (rows
// top to bottom), with no gamma or colour chunk: the bytes are data (the
// RGBD faces of a Babylon .env).
// zlib level 1 by default: several times faster than 6, for about 20 % more bytes.
std::vector<uint8_t> encode_png8(int width, int height, int channels, const uint8_t* values, int level = 1);
// write_png16 at zlib level 1 (the exported LUTs).
void write_png16_fast(const std::string& path, int width, int height, int channels, FloatSpan values);
// Radiance HDR (RGBE; run-length scanlines of literal dumps) from an RGB float image (rows top to bottom).
// Returns how many texels were clamped to RGBE's largest value (about 1.69e38).
uint64_t write_hdr(const std::string& path, const Image& img);
// RGBE of one colour, as Ward's float2rgbe (exposed for tests); true when it
// was clamped to RGBE's largest value (its hue kept).
bool float_to_rgbe(const float rgb[3], uint8_t out[4]);
// A file of these bytes (exported containers).
void write_bytes(const std::string& path, const std::vector<uint8_t>& bytes);
// A text file (JSON) of these characters.
void write_text(const std::string& path, const std::string& text);

}  // namespace iblbake::io
