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

extern "C" __attribute__((visibility("default"))) int iblbake_oiio_read(const char* path, IblbakeOiioImage* out,
                                                                        char* error, int error_size) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        copy_text(error, error_size, OIIO::geterror());
        return 0;
    }
    const OIIO::ImageSpec spec = in->spec();
    if (spec.width < 1 || spec.height < 1 || spec.nchannels < 1 || spec.depth > 1) {
        copy_text(error, error_size, "image has no pixels");
        return 0;
    }
    const size_t n = size_t(spec.width) * spec.height * spec.nchannels;
    float* data = static_cast<float*>(std::malloc(n * sizeof(float)));
    if (!data) {
        copy_text(error, error_size, "out of memory");
        return 0;
    }
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, data)) {
        copy_text(error, error_size, in->geterror());
        std::free(data);
        return 0;
    }
    out->width = spec.width;
    out->height = spec.height;
    out->full_width = spec.full_width;
    out->full_height = spec.full_height;
    out->x_offset = spec.x - spec.full_x;
    out->y_offset = spec.y - spec.full_y;
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
