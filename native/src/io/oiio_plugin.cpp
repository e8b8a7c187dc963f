// libiblbake_oiio.so: reads any image OpenImageIO reads (HDR, PNG, JPEG,
// TIFF, ...), loaded by image_io.cpp only for files that are not EXR.
#include <OpenImageIO/imageio.h>

#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <string>

#include "raw_pixels.h"

using iblbake::io::detail::IblbakeOiioImage;

namespace {
void copy_text(char* dst, size_t size, const std::string& src) {
    std::strncpy(dst, src.c_str(), size - 1);
    dst[size - 1] = '\0';
}
}  // namespace

// The image as it is shown: EXIF/TIFF Orientation 2 to 8 (also what a
// Radiance file's resolution string says, "+Y H +X W" and the like) turns
// the stored pixels. Orientation 5 to 8 swap width and height.
float* reorient(const float* in, int w, int h, int nch, int orientation, int& ow, int& oh) {
    const bool swap = orientation >= 5;
    ow = swap ? h : w;
    oh = swap ? w : h;
    float* out = static_cast<float*>(std::malloc(size_t(w) * h * nch * sizeof(float)));
    if (!out) return nullptr;
    for (int y = 0; y < oh; ++y)
        for (int x = 0; x < ow; ++x) {
            int sx = x, sy = y;  // the stored texel shown at (x, y)
            switch (orientation) {
                case 2: sx = w - 1 - x; break;
                case 3: sx = w - 1 - x, sy = h - 1 - y; break;
                case 4: sy = h - 1 - y; break;
                case 5: sx = y, sy = x; break;
                case 6: sx = y, sy = h - 1 - x; break;
                case 7: sx = w - 1 - y, sy = h - 1 - x; break;
                case 8: sx = w - 1 - y, sy = x; break;
                default: break;
            }
            std::memcpy(out + (size_t(y) * ow + x) * nch, in + (size_t(sy) * w + sx) * nch, nch * sizeof(float));
        }
    return out;
}

// A Radiance file's orientation from its resolution line, as the EXIF
// number of the same turn (0: no such line). OpenImageIO 2.4 reads
// "+X W +Y H" as 6 and "-X W -Y H" as 8, the reverse of what they mean: a
// first scanline that is the left column read bottom to top is 8.
int radiance_orientation(const char* path) {
    std::FILE* f = std::fopen(path, "rb");
    if (!f) return 0;
    char line[256];
    bool blank = false;
    int orientation = 0;
    for (int n = 0; n < 256 && std::fgets(line, sizeof line, f); ++n) {
        if (!blank) {
            blank = line[0] == '\n' || (line[0] == '\r' && line[1] == '\n');
            continue;
        }
        char a[3] = {0}, b[3] = {0};
        if (std::sscanf(line, "%2s %*d %2s %*d", a, b) == 2) {
            static const char* kOrder[8] = {"-Y+X", "-Y-X", "+Y-X", "+Y+X", "+X-Y", "-X-Y", "-X+Y", "+X+Y"};
            const std::string key = std::string(a) + b;
            for (int k = 0; k < 8; ++k)
                if (key == kOrder[k]) orientation = k + 1;
        }
        break;
    }
    std::fclose(f);
    return orientation;
}

namespace {
// Opens `path` with the reader of `format` and checks its first image's
// size: 1 (in, spec set), 0 (error set) or 2 (declared size beyond the
// limits; out's width, height, channels set).
int open_checked(const char* path, const char* format, long long max_side, long long max_values,
                 std::unique_ptr<OIIO::ImageInput>& in, OIIO::ImageSpec& spec, IblbakeOiioImage* out, char* error,
                 int error_size) {
    auto made = OIIO::ImageInput::create(format);
    if (!made) {
        copy_text(error, error_size, "no OpenImageIO reader for format '" + std::string(format) + "'");
        return 0;
    }
    in.reset(made.release());
    // PFM stores its rows bottom to top: OpenImageIO 2.5 and later turn them
    // the right way up only when asked (an open without a configuration does
    // not; 2.4 always did).
    OIIO::ImageSpec config;
    config.attribute("pnm:pfmflip", 1);
    if (!in->open(path, spec, config)) {
        std::string why = in->geterror();
        if (why.empty()) why = "not a readable " + std::string(format) + " file";
        copy_text(error, error_size, why);
        return 0;
    }
    if (spec.width < 1 || spec.height < 1 || spec.nchannels < 1 || spec.depth > 1) {
        copy_text(error, error_size, "image has no pixels");
        return 0;
    }
    out->width = spec.width;
    out->height = spec.height;
    out->channels = spec.nchannels;
    if (spec.width > max_side || spec.height > max_side ||
        (long long)spec.width * spec.height * spec.nchannels > max_values)
        return 2;
    return 1;
}

// What the file says of its pixels besides their size (the caller's header).
void describe(const OIIO::ImageSpec& spec, const OIIO::ImageInput& in, IblbakeOiioImage* out) {
    out->channels = spec.nchannels;
    out->alpha_channel = spec.alpha_channel;
    out->is_float = spec.format.is_floating_point() ? 1 : 0;
    copy_text(out->colorspace, sizeof(out->colorspace), spec.get_string_attribute("oiio:ColorSpace"));
    copy_text(out->format, sizeof(out->format), in.format_name());
}

// The file's Orientation (EXIF's numbers: 1 to 8 are defined).
int orientation_of(const char* path, const char* format, const OIIO::ImageSpec& spec) {
    const int from_hdr = std::strcmp(format, "hdr") == 0 ? radiance_orientation(path) : 0;
    return from_hdr ? from_hdr : spec.get_int_attribute("Orientation", 1);
}

struct RowHandle {
    std::unique_ptr<OIIO::ImageInput> in;
    int width = 0, height = 0, channels = 0;
};
}  // namespace

// The streaming bake's reader: the file opened, its header in `out` (data
// null), rows read by iblbake_oiio_read_rows_v3. Returns null with *rc 0
// (error set), 2 (declared size beyond the limits) or 3 (the file is read
// whole only: it is turned by its Orientation, or its data window is not
// its display window).
extern "C" __attribute__((visibility("default"))) void* iblbake_oiio_open_rows_v3(
    const char* path, const char* format, long long max_side, long long max_values, IblbakeOiioImage* out, int* rc,
    char* error, int error_size) {
    std::unique_ptr<OIIO::ImageInput> in;
    OIIO::ImageSpec spec;
    *rc = open_checked(path, format, max_side, max_values, in, spec, out, error, error_size);
    if (*rc != 1) return nullptr;
    const bool windowed = spec.x != 0 || spec.y != 0 || spec.full_x != 0 || spec.full_y != 0 ||
                          (spec.full_width > 0 && spec.full_width != spec.width) ||
                          (spec.full_height > 0 && spec.full_height != spec.height);
    if (orientation_of(path, format, spec) != 1 || windowed) {
        *rc = 3;
        return nullptr;
    }
    describe(spec, *in, out);
    out->full_width = out->full_height = out->x_offset = out->y_offset = 0;
    out->data = nullptr;
    auto* h = new (std::nothrow) RowHandle{std::move(in), spec.width, spec.height, spec.nchannels};
    if (!h) {
        copy_text(error, error_size, "out of memory");
        *rc = 0;
    }
    return h;
}

// Rows y0 .. y0 + rows - 1 of the file's first image into out (rows x width
// x channels floats, the file's channels): 1, or 0 with error set.
extern "C" __attribute__((visibility("default"))) int iblbake_oiio_read_rows_v3(void* handle, int y0, int rows,
                                                                               float* out, char* error,
                                                                               int error_size) {
    auto* h = static_cast<RowHandle*>(handle);
    if (y0 < 0 || rows < 1 || y0 + rows > h->height) {
        copy_text(error, error_size, "rows outside the image");
        return 0;
    }
    if (!h->in->read_scanlines(0, 0, y0, y0 + rows, 0, 0, h->channels, OIIO::TypeDesc::FLOAT, out)) {
        std::string why = h->in->geterror();
        if (why.empty()) why = "the pixels cannot be decoded";
        copy_text(error, error_size, why);
        return 0;
    }
    return 1;
}

extern "C" __attribute__((visibility("default"))) void iblbake_oiio_close_rows_v3(void* handle) {
    auto* h = static_cast<RowHandle*>(handle);
    if (h && h->in) h->in->close();
    delete h;
}

// Only the reader of `format` is tried: OpenImageIO's ImageInput::open(path)
// would try every reader it has on a file none of them takes (a gigabyte of
// zeros kept it busy for minutes).
extern "C" __attribute__((visibility("default"))) int iblbake_oiio_read_v2(const char* path, const char* format,
                                                                           long long max_side, long long max_values,
                                                                           IblbakeOiioImage* out, char* error,
                                                                           int error_size) {
    std::unique_ptr<OIIO::ImageInput> in;
    OIIO::ImageSpec spec;
    const int opened = open_checked(path, format, max_side, max_values, in, spec, out, error, error_size);
    if (opened != 1) return opened;
    const size_t n = size_t(spec.width) * spec.height * spec.nchannels;
    float* data = static_cast<float*>(std::malloc(n * sizeof(float)));
    if (!data) {
        copy_text(error, error_size, "out of memory");
        return 0;
    }
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, data)) {
        std::string why = in->geterror();
        if (why.empty()) why = "the pixels cannot be decoded";
        copy_text(error, error_size, why);
        std::free(data);
        return 0;
    }
    const int orientation = orientation_of(path, format, spec);
    if (orientation < 1 || orientation > 8) {
        copy_text(error, error_size, "its Orientation is " + std::to_string(orientation) + " (1 to 8 are defined)");
        std::free(data);
        return 0;
    }
    if (orientation != 1) {
        int w = 0, h = 0;
        float* turned = reorient(data, spec.width, spec.height, spec.nchannels, orientation, w, h);
        std::free(data);
        if (!turned) {
            copy_text(error, error_size, "out of memory");
            return 0;
        }
        data = turned;
        // The data window alone (a display window's offsets are in stored order).
        spec.width = spec.full_width = w;
        spec.height = spec.full_height = h;
        spec.x = spec.full_x = spec.y = spec.full_y = 0;
    }
    out->width = spec.width;
    out->height = spec.height;
    out->full_width = spec.full_width;
    out->full_height = spec.full_height;
    // Windows far outside int's range count as none (the data window alone is baked).
    const long long ox = (long long)spec.x - spec.full_x, oy = (long long)spec.y - spec.full_y;
    const bool sane = ox > -(1LL << 30) && ox < (1LL << 30) && oy > -(1LL << 30) && oy < (1LL << 30);
    out->x_offset = sane ? int(ox) : 0;
    out->y_offset = sane ? int(oy) : 0;
    if (!sane) out->full_width = out->full_height = 0;
    describe(spec, *in, out);
    out->data = data;
    in->close();
    return 1;
}

extern "C" __attribute__((visibility("default"))) void iblbake_oiio_free(float* data) { std::free(data); }
