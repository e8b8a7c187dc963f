// What a file reader hands to read_image() before the shared finishing
// (display window, channel choice, sRGB decode). Private to io/.
#pragma once
#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "iblbake/image/image.h"

namespace iblbake::io::detail {

struct RawPixels {
    int width = 0, height = 0;              // data window
    int full_width = 0, full_height = 0;    // display window (0: same as data)
    int x_offset = 0, y_offset = 0;         // data window origin in the display window
    int channels = 0, alpha_channel = -1;   // interleaved channels; which is alpha
    bool straight_alpha = false;            // colour not yet multiplied by alpha (PNG); done as Cycles does
    bool is_float = true;                   // false: 8/16-bit integers normalised to [0, 1]
    std::string colorspace;                 // as the file declares it ("" if it does not)
    std::string format;                     // "openexr", "png", "hdr", ...
    FloatBuffer data;                       // width * height * channels
    std::vector<std::string> warnings;      // what the reader chose (a layer, a part, grey)
};

// A file's rows as its reader decodes them (the streaming bake's readers):
// the header as RawPixels holds it (no data), and rows of `channels` floats.
// read_image's finishing (channel choice, alpha, sRGB decode) is applied by
// io::open_rows's reader. Errors are std::runtime_error with the reason alone.
class RawRows {
public:
    virtual ~RawRows() = default;
    RawPixels header;
    virtual int preferred_band() const = 0;
    // Rows y0 .. y0 + rows - 1 into out: rows x width x channels floats.
    virtual void read(int y0, int rows, float* out) = 0;
};
// A decoder that gives its rows in order (libpng, libjpeg): read() starts it
// again for a row before the next one, skips to y0, and takes at most 64
// rows at a time.
class SequentialRows : public RawRows {
public:
    int preferred_band() const override { return kStep; }
    void read(int y0, int rows, float* out) final {
        if (y0 < next_) restart();
        while (next_ < y0) take(std::min(kStep, y0 - next_));
        const size_t row_values = size_t(header.width) * header.channels;
        for (int done = 0; done < rows;) {
            const int n = std::min(kStep, rows - done);
            take(n);
            to_float(n, out + size_t(done) * row_values);
            done += n;
        }
    }

protected:
    static constexpr int kStep = 64;
    int next_ = 0;  // the next row the decoder gives
    // The decoder at row 0 again (next_ = 0).
    virtual void restart() = 0;
    // The next n rows decoded into the decoder's buffer (next_ += n).
    virtual void take(int n) = 0;
    // The n rows taken last, as floats in [0, 1].
    virtual void to_float(int n, float* out) const = 0;
};
// 8- or 16-bit values (host order) as floats in [0, 1], as read_image makes them (png_file.cpp).
void integers_to_float(const unsigned char* in, size_t values, int bytes, float* out);
// A PNG's rows (null for an interlaced one: every pass covers every row) and a JPEG's.
std::unique_ptr<RawRows> png_rows(const std::string& path, uintmax_t file_size);
std::unique_ptr<RawRows> jpeg_rows(const std::string& path, uintmax_t file_size);
// A Radiance RGBE file's rows (hdr_file.cpp), or null for one stored turned
// (a resolution line other than -Y H +X W), which the plugin reads whole.
std::unique_ptr<RawRows> hdr_rows(const std::string& path, uintmax_t file_size);
// Every row of `rows` as one RawPixels (read_image's whole read of a format read by rows).
RawPixels read_all_rows(RawRows& rows, const std::function<void(double)>& progress);

// The OpenEXR reader and writer (exr_file.cpp) and the PNG writer (png_file.cpp); the writers take
// their pixels in bands of rows from `fill` (io::write_exr and friends hand them a whole buffer so).
bool is_exr(const std::string& path);
// read_image's error for a file it cannot read: "cannot read '<path>': <why>",
// on one line, unprintable bytes escaped (image_io.cpp; ExrRowReader's too).
[[noreturn]] void fail_reading(const std::string& path, const std::string& why);
// Throws unless width x height x channels floats is within the maximum size
// and plausible for a file of `file_size` bytes (io/image_io.h).
void check_declared(int64_t width, int64_t height, int channels, uintmax_t file_size);
// `progress` (may be empty): the share of rows decoded, after each band.
RawPixels read_exr(const std::string& path, uintmax_t file_size, const std::function<void(double)>& progress);
RawPixels read_png(const std::string& path, uintmax_t file_size, const std::function<void(double)>& progress);
RawPixels read_jpeg(const std::string& path, uintmax_t file_size);
// Throws unless every strip or tile a TIFF's first image lists lies within
// the file (libtiff reads a cut file's missing strips as black, quietly).
void check_tiff_complete(const std::string& path, uintmax_t file_size);
void write_exr_file_rows(const std::string& path, int width, int height, int channels, bool half,
                         const std::function<void(int y0, int rows, float* out)>& fill);
// zlib level 6 unless told (1 is several times faster for 20 % more bytes).
void write_png_file_rows(const std::string& path, int width, int height, int channels, int bits,
                         const std::function<void(int y0, int rows, float* out)>& fill, int level = 6);
std::vector<unsigned char> encode_png8_memory(int width, int height, int channels, const unsigned char* values,
                                              int level);

// The plugin's C interface (oiio_plugin.cpp, built as libiblbake_oiio.so and
// loaded only for files that are not EXR, so that baking EXR never loads
// OpenImageIO's few hundred libraries).
extern "C" {
struct IblbakeOiioImage {
    int width, height, full_width, full_height, x_offset, y_offset, channels, alpha_channel, is_float;
    char colorspace[64];
    char format[32];
    float* data;  // malloc'ed by the plugin; free with iblbake_oiio_free
};
// Reads `path` with OpenImageIO's reader of `format` alone ("png", "jpeg", ...).
// Returns 1 on success; 0 with `error` set on failure; 2 when the declared
// size (out->width, height, channels) exceeds max_side or max_values floats,
// before any pixel is allocated.
typedef int (*IblbakeOiioRead)(const char* path, const char* format, long long max_side, long long max_values,
                               IblbakeOiioImage* out, char* error, int error_size);
typedef void (*IblbakeOiioFree)(float* data);
// Row by row (the streaming bake): open fills the header (data null) and
// returns a handle, or null with *rc 0 (error set), 2 (declared size beyond
// the limits) or 3 (read whole only: turned by its Orientation, or a data
// window of its own); read_rows writes rows x width x channels floats.
typedef void* (*IblbakeOiioOpenRows)(const char* path, const char* format, long long max_side, long long max_values,
                                     IblbakeOiioImage* header, int* rc, char* error, int error_size);
typedef int (*IblbakeOiioReadRows)(void* handle, int y0, int rows, float* out, char* error, int error_size);
typedef void (*IblbakeOiioCloseRows)(void* handle);
}

}  // namespace iblbake::io::detail
