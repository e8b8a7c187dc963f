// JPEG files through libjpeg directly (not OpenImageIO, whose JPEG reader
// parses IPTC metadata past the end of its buffer: found by scripts/fuzz.sh
// in OpenImageIO 2.4). libjpeg's errors are caught as text, and its warning
// that the data ended early (it would fill the missing rows with grey) is an
// error here. Grey and RGB (YCbCr) files; CMYK is refused.
#include <cstddef>
#include <cstdio>
// jpeglib.h needs size_t and FILE declared first.
#include <jerror.h>
#include <jpeglib.h>

#include <csetjmp>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "raw_pixels.h"

namespace iblbake::io::detail {

namespace {
struct ErrorManager {
    jpeg_error_mgr pub;
    std::jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
};

extern "C" void jpeg_fail(j_common_ptr cinfo) {
    auto* err = reinterpret_cast<ErrorManager*>(cinfo->err);
    (*cinfo->err->format_message)(cinfo, err->message);
    std::longjmp(err->jump, 1);
}

extern "C" void jpeg_message(j_common_ptr cinfo, int level) {
    // Warnings (level -1) that mean pixels are missing are errors; others are ignored, never printed.
    if (level < 0 && (cinfo->err->msg_code == JWRN_JPEG_EOF || cinfo->err->msg_code == JWRN_HIT_MARKER ||
                      cinfo->err->msg_code == JWRN_MUST_RESYNC))
        jpeg_fail(cinfo);
}

struct JpegOut {
    JDIMENSION w = 0, h = 0;
    int channels = 0;
    std::vector<unsigned char> buffer;
};

// Every libjpeg call, in a frame that holds no C++ object: an error longjmps here.
bool jpeg_read_core(jpeg_decompress_struct* cinfo, ErrorManager* err, JpegOut* o, std::FILE* f, uintmax_t file_size,
                    std::string* why) {
    if (setjmp(err->jump)) {
        *why = err->message;
        return false;
    }
    jpeg_create_decompress(cinfo);
    jpeg_stdio_src(cinfo, f);
    jpeg_read_header(cinfo, TRUE);
    if (cinfo->jpeg_color_space == JCS_CMYK || cinfo->jpeg_color_space == JCS_YCCK) {
        *why = "file is CMYK, which iblbake does not read: convert it to RGB";
        return false;
    }
    cinfo->out_color_space = cinfo->num_components == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_calc_output_dimensions(cinfo);
    o->w = cinfo->output_width;
    o->h = cinfo->output_height;
    o->channels = cinfo->output_components;
    check_declared(o->w, o->h, o->channels, file_size);  // throws before the pixels are allocated
    jpeg_start_decompress(cinfo);
    const size_t stride = size_t(o->w) * o->channels;
    o->buffer.resize(stride * o->h);
    while (cinfo->output_scanline < cinfo->output_height) {
        JSAMPROW row = o->buffer.data() + stride * cinfo->output_scanline;
        jpeg_read_scanlines(cinfo, &row, 1);
    }
    jpeg_finish_decompress(cinfo);
    return true;
}
}  // namespace

RawPixels read_jpeg(const std::string& path, uintmax_t file_size) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!f) throw std::runtime_error("cannot open the file");
    jpeg_decompress_struct cinfo{};
    ErrorManager err{};
    cinfo.err = jpeg_std_error(&err.pub);
    err.pub.error_exit = jpeg_fail;
    err.pub.emit_message = jpeg_message;
    JpegOut o;
    std::string why;
    bool ok = false;
    try {
        ok = jpeg_read_core(&cinfo, &err, &o, f.get(), file_size, &why);
    } catch (...) {
        jpeg_destroy_decompress(&cinfo);
        throw;
    }
    jpeg_destroy_decompress(&cinfo);
    if (!ok) throw std::runtime_error("JPEG " + why);
    RawPixels out;
    out.format = "jpeg";
    out.width = int(o.w);
    out.height = int(o.h);
    out.channels = o.channels;
    out.is_float = false;
    out.colorspace = "sRGB";
    out.data.resize(o.buffer.size());
    for (size_t k = 0; k < o.buffer.size(); ++k) out.data[k] = float(o.buffer[k]) * (1.0f / 255.0f);
    return out;
}

}  // namespace iblbake::io::detail
