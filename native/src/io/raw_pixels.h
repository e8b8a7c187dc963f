// What a file reader hands to read_image() before the shared finishing
// (display window, channel choice, sRGB decode). Private to io/.
#pragma once
#include <functional>
#include <string>
#include <vector>

namespace iblbake::io::detail {

struct RawPixels {
    int width = 0, height = 0;              // data window
    int full_width = 0, full_height = 0;    // display window (0: same as data)
    int x_offset = 0, y_offset = 0;         // data window origin in the display window
    int channels = 0, alpha_channel = -1;   // interleaved channels; which is alpha
    bool is_float = true;                   // false: 8/16-bit integers normalised to [0, 1]
    std::string colorspace;                 // as the file declares it ("" if it does not)
    std::string format;                     // "openexr", "png", "hdr", ...
    std::vector<float> data;                // width * height * channels
};

// The OpenEXR reader and writer (exr_file.cpp) and the PNG writer (png_file.cpp); the writers take
// their pixels in bands of rows from `fill` (io::write_exr and friends hand them a whole buffer so).
bool is_exr(const std::string& path);
RawPixels read_exr(const std::string& path);
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
typedef int (*IblbakeOiioRead)(const char* path, IblbakeOiioImage* out, char* error, int error_size);
typedef void (*IblbakeOiioFree)(float* data);
}

}  // namespace iblbake::io::detail
