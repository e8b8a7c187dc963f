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

// libjpeg's errors and warnings through ErrorManager (jpeg_fail, jpeg_message).
void use_errors(jpeg_decompress_struct& cinfo, ErrorManager& err) {
    cinfo.err = jpeg_std_error(&err.pub);
    err.pub.error_exit = jpeg_fail;
    err.pub.emit_message = jpeg_message;
}

// The header of a JPEG as read (grey or RGB, 8-bit sRGB).
RawPixels jpeg_header(const JpegOut& o) {
    RawPixels out;
    out.format = "jpeg";
    out.width = int(o.w);
    out.height = int(o.h);
    out.channels = o.channels;
    out.is_float = false;
    out.colorspace = "sRGB";
    return out;
}

// The decompressor's creation (it fails only out of memory), in a frame of its own.
bool jpeg_create_core(jpeg_decompress_struct* cinfo, ErrorManager* err) {
    if (setjmp(err->jump)) return false;
    jpeg_create_decompress(cinfo);
    return true;
}

// The header, up to the first scanline, in a frame that holds no C++ object:
// an error longjmps here. The decompressor was created by the caller.
bool jpeg_open_core(jpeg_decompress_struct* cinfo, ErrorManager* err, JpegOut* o, std::FILE* f, uintmax_t file_size,
                    std::string* why) {
    if (setjmp(err->jump)) {
        *why = err->message;
        return false;
    }
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
    return true;
}

// Every libjpeg call of a whole read, each in a frame that holds no C++ object.
bool jpeg_read_core(jpeg_decompress_struct* cinfo, ErrorManager* err, JpegOut* o, std::FILE* f, uintmax_t file_size,
                    std::string* why) {
    if (!jpeg_open_core(cinfo, err, o, f, file_size, why)) return false;
    if (setjmp(err->jump)) {
        *why = err->message;
        return false;
    }
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
    use_errors(cinfo, err);
    JpegOut o;
    std::string why;
    bool ok = false;
    if (!jpeg_create_core(&cinfo, &err)) throw std::runtime_error("libjpeg could not start");
    try {
        ok = jpeg_read_core(&cinfo, &err, &o, f.get(), file_size, &why);
    } catch (...) {
        jpeg_destroy_decompress(&cinfo);
        throw;
    }
    jpeg_destroy_decompress(&cinfo);
    if (!ok) throw std::runtime_error("JPEG " + why);
    RawPixels out = jpeg_header(o);
    out.data.resize(o.buffer.size());
    integers_to_float(o.buffer.data(), o.buffer.size(), 1, out.data.data());
    return out;
}

namespace {
// `rows` scanlines into `buffer` (`stride` bytes each), and the decompression's
// end after the last one: libjpeg's calls in a frame that holds no C++ object.
bool jpeg_rows_core(jpeg_decompress_struct* cinfo, ErrorManager* err, unsigned char* buffer, size_t stride, int rows,
                    std::string* why) {
    if (setjmp(err->jump)) {
        *why = err->message;
        return false;
    }
    for (int k = 0; k < rows; ++k) {
        JSAMPROW row = buffer + stride * size_t(k);
        jpeg_read_scanlines(cinfo, &row, 1);
    }
    if (cinfo->output_scanline >= cinfo->output_height) jpeg_finish_decompress(cinfo);
    return true;
}

// A JPEG's scanlines in order (a row before the last one read opens the file
// again and skips to it).
class JpegRows final : public SequentialRows {
public:
    JpegRows(std::string path, uintmax_t file_size) : path_(std::move(path)), file_size_(file_size) {
        try {
            open();
        } catch (...) {  // no destructor runs for a constructor that throws
            close();
            throw;
        }
    }
    ~JpegRows() override { close(); }
    JpegRows(const JpegRows&) = delete;
    JpegRows& operator=(const JpegRows&) = delete;

private:
    void restart() override {
        close();
        open();
    }
    void take(int n) override {
        const size_t stride = size_t(o_.w) * o_.channels;
        buffer_.resize(stride * size_t(n));
        std::string why;
        if (!jpeg_rows_core(&cinfo_, &err_, buffer_.data(), stride, n, &why)) throw std::runtime_error("JPEG " + why);
        next_ += n;
    }
    void to_float(int n, float* out) const override {
        integers_to_float(buffer_.data(), size_t(n) * o_.w * o_.channels, 1, out);
    }

    void open() {
        f_ = std::fopen(path_.c_str(), "rb");
        if (!f_) throw std::runtime_error("cannot open the file");
        cinfo_ = jpeg_decompress_struct{};
        err_ = ErrorManager{};
        use_errors(cinfo_, err_);
        if (!jpeg_create_core(&cinfo_, &err_)) throw std::runtime_error("libjpeg could not start");
        created_ = true;
        std::string why;
        if (!jpeg_open_core(&cinfo_, &err_, &o_, f_, file_size_, &why)) throw std::runtime_error("JPEG " + why);
        next_ = 0;
        header = jpeg_header(o_);
    }
    void close() {
        if (created_) jpeg_destroy_decompress(&cinfo_);
        created_ = false;
        if (f_) std::fclose(f_);
        f_ = nullptr;
    }
    std::string path_;
    uintmax_t file_size_;
    std::FILE* f_ = nullptr;
    jpeg_decompress_struct cinfo_{};
    ErrorManager err_{};
    bool created_ = false;
    JpegOut o_;
    std::vector<unsigned char> buffer_;
};
}  // namespace

std::unique_ptr<RawRows> jpeg_rows(const std::string& path, uintmax_t file_size) {
    return std::make_unique<JpegRows>(path, file_size);
}

}  // namespace iblbake::io::detail
