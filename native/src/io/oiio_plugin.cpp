// libiblbake_oiio.so: reads any image OpenImageIO reads (HDR, PNG, JPEG,
// TIFF, ...), loaded by image_io.cpp only for files that are not EXR.
#include <OpenImageIO/imageio.h>

#include <cstdlib>
#include <cstring>
#include <string>

#include "raw_pixels.h"

using iblbake::io::detail::IblbakeOiioImage;

namespace {
void copy_text(char* dst, size_t size, const std::string& src) {
    std::strncpy(dst, src.c_str(), size - 1);
    dst[size - 1] = '\0';
}
}  // namespace

// Only the reader of `format` is tried: OpenImageIO's ImageInput::open(path)
// would try every reader it has on a file none of them takes (a gigabyte of
// zeros kept it busy for minutes).
extern "C" __attribute__((visibility("default"))) int iblbake_oiio_read_v2(const char* path, const char* format,
                                                                           long long max_side, long long max_values,
                                                                           IblbakeOiioImage* out, char* error,
                                                                           int error_size) {
    auto in = OIIO::ImageInput::create(format);
    if (!in) {
        copy_text(error, error_size, "no OpenImageIO reader for format '" + std::string(format) + "'");
        return 0;
    }
    OIIO::ImageSpec spec;
    if (!in->open(path, spec)) {
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
    out->channels = spec.nchannels;
    out->alpha_channel = spec.alpha_channel;
    out->is_float = spec.format.is_floating_point() ? 1 : 0;
    copy_text(out->colorspace, sizeof(out->colorspace), spec.get_string_attribute("oiio:ColorSpace"));
    copy_text(out->format, sizeof(out->format), in->format_name());
    out->data = data;
    in->close();
    return 1;
}

extern "C" __attribute__((visibility("default"))) void iblbake_oiio_free(float* data) { std::free(data); }
