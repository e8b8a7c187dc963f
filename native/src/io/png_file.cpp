// PNG files through libpng. Writing: 8 or 16 bits, grey, RGB or RGBA;
// values arrive already encoded (8-bit: sRGB or RGBM; 16-bit: linear, marked
// gAMA 1). Reading: any PNG (palette, grey, alpha, 1..16 bits, interlaced),
// libpng's errors and warnings caught as text (never printed), the declared
// size checked before the pixels are allocated.
#include <png.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "raw_pixels.h"

namespace iblbake::io::detail {

namespace {
struct ReadState {
    std::jmp_buf jump;
    std::string error;
};

extern "C" void png_read_error(png_structp png, png_const_charp msg) {
    auto* st = static_cast<ReadState*>(png_get_error_ptr(png));
    st->error = msg ? msg : "libpng error";
    std::longjmp(st->jump, 1);
}
extern "C" void png_read_warning(png_structp, png_const_charp) {}  // benign ones; damage is an error
}  // namespace

namespace {
struct PngOut {
    png_uint_32 w = 0, h = 0;
    int channels = 0, bytes = 1;
    bool linear = false;
    std::vector<unsigned char> buffer;
    std::vector<png_bytep> rows;
};

// The header and the transforms to 8- or 16-bit grey, RGB or RGBA, in a
// frame of its own that holds no C++ object: an error longjmps back here and
// the caller throws. The passes (7 for an interlaced file) in *passes.
bool png_open_core(png_structp png, png_infop info, ReadState* st, PngOut* o, FILE* f, uintmax_t file_size,
                   int* passes) {
    if (setjmp(st->jump)) return false;
    png_init_io(png, f);
    png_read_info(png, info);
    o->w = png_get_image_width(png, info);
    o->h = png_get_image_height(png, info);
    const int type = png_get_color_type(png, info), depth = png_get_bit_depth(png, info);
    if (type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (type == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    if (depth == 16) png_set_swap(png);  // host order
    *passes = png_set_interlace_handling(png);
    png_read_update_info(png, info);
    o->channels = png_get_channels(png, info);
    o->bytes = png_get_bit_depth(png, info) == 16 ? 2 : 1;
    check_declared(o->w, o->h, o->channels, file_size);  // throws before anything is allocated
    double gamma = 0.0;
    o->linear = png_get_gAMA(png, info, &gamma) && std::fabs(gamma - 1.0) < 0.01;
    if (png_get_rowbytes(png, info) != size_t(o->w) * o->channels * o->bytes) {
        st->error = "row size is inconsistent";
        return false;
    }
    return true;
}

// Every libpng call of a whole read, each in a frame that holds no C++ object.
bool png_read_core(png_structp png, png_infop info, ReadState* st, PngOut* o, FILE* f, uintmax_t file_size,
                   const std::function<void(double)>* progress) {
    int passes = 1;
    if (!png_open_core(png, info, st, o, f, file_size, &passes)) return false;
    if (setjmp(st->jump)) return false;
    const size_t stride = size_t(o->w) * o->channels * o->bytes;
    o->buffer.resize(stride * o->h);
    o->rows.resize(o->h);
    for (png_uint_32 y = 0; y < o->h; ++y) o->rows[y] = o->buffer.data() + y * stride;
    // Bands of 64 rows (every pass of an interlaced file), progress after each.
    for (int pass = 0; pass < passes; ++pass)
        for (png_uint_32 y = 0; y < o->h; y += 64) {
            const png_uint_32 n = std::min<png_uint_32>(64, o->h - y);
            png_read_rows(png, o->rows.data() + y, nullptr, n);
            if (*progress) (*progress)((double(pass) * o->h + y + n) / (double(passes) * o->h));
        }
    png_read_end(png, nullptr);
    return true;
}

// The header of a PNG as read (transformed to 8- or 16-bit grey, RGB or RGBA).
RawPixels png_header(const PngOut& o) {
    RawPixels out;
    out.format = "png";
    out.width = int(o.w);
    out.height = int(o.h);
    out.channels = o.channels;
    out.alpha_channel = o.channels == 2 || o.channels == 4 ? o.channels - 1 : -1;
    out.straight_alpha = out.alpha_channel >= 0;  // PNG's alpha is never premultiplied
    out.is_float = false;
    out.colorspace = o.linear ? "linear" : "sRGB";
    return out;
}
}  // namespace

void integers_to_float(const unsigned char* in, size_t values, int bytes, float* out) {
    if (bytes == 2) {
        for (size_t k = 0; k < values; ++k) {
            uint16_t v;
            std::memcpy(&v, in + 2 * k, 2);
            out[k] = float(v) * (1.0f / 65535.0f);
        }
    } else {
        for (size_t k = 0; k < values; ++k) out[k] = float(in[k]) * (1.0f / 255.0f);
    }
}


RawPixels read_png(const std::string& path, uintmax_t file_size, const std::function<void(double)>& progress) {
    std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!f) throw std::runtime_error("cannot open the file");
    ReadState st;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &st, png_read_error, png_read_warning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    struct Guard {
        png_structp* png;
        png_infop* info;
        ~Guard() {
            if (*png) png_destroy_read_struct(png, info, nullptr);
        }
    } guard{&png, &info};
    if (!png || !info) throw std::runtime_error("libpng could not start");
    PngOut o;
    if (!png_read_core(png, info, &st, &o, f.get(), file_size, &progress)) throw std::runtime_error("PNG " + st.error);
    RawPixels out = png_header(o);
    std::vector<png_bytep>().swap(o.rows);
    out.data.resize(size_t(o.w) * o.h * o.channels);
    integers_to_float(o.buffer.data(), out.data.size(), o.bytes, out.data.data());
    return out;
}

namespace {
// `rows` rows into `rows_at` (row pointers), and the file's end after its
// last row (`end`): libpng's calls in a frame that holds no C++ object.
bool png_rows_core(png_structp png, ReadState* st, png_bytepp rows_at, png_uint_32 rows, bool end) {
    if (setjmp(st->jump)) return false;
    png_read_rows(png, rows_at, nullptr, rows);
    if (end) png_read_end(png, nullptr);
    return true;
}

// A non-interlaced PNG, rows in order (a row before the last one read opens
// the file again and skips to it).
class PngRows final : public SequentialRows {
public:
    PngRows(std::string path, uintmax_t file_size) : path_(std::move(path)), file_size_(file_size) {
        try {
            open();
        } catch (...) {  // no destructor runs for a constructor that throws
            close();
            throw;
        }
    }
    ~PngRows() override { close(); }
    PngRows(const PngRows&) = delete;
    PngRows& operator=(const PngRows&) = delete;

    bool interlaced() const { return passes_ > 1; }

private:
    void restart() override {
        close();
        open();
    }
    // The next n rows into buffer_ (the file's end checked after its last row).
    void take(int n) override {
        const size_t stride = size_t(o_.w) * o_.channels * o_.bytes;
        buffer_.resize(stride * size_t(n));
        row_at_.resize(size_t(n));
        for (int k = 0; k < n; ++k) row_at_[k] = buffer_.data() + size_t(k) * stride;
        if (!png_rows_core(png_, &st_, row_at_.data(), png_uint_32(n), next_ + n == int(o_.h)))
            throw std::runtime_error("PNG " + st_.error);
        next_ += n;
    }
    void to_float(int n, float* out) const override {
        integers_to_float(buffer_.data(), size_t(n) * o_.w * o_.channels, o_.bytes, out);
    }

    void open() {
        f_ = std::fopen(path_.c_str(), "rb");
        if (!f_) throw std::runtime_error("cannot open the file");
        png_ = png_create_read_struct(PNG_LIBPNG_VER_STRING, &st_, png_read_error, png_read_warning);
        info_ = png_ ? png_create_info_struct(png_) : nullptr;
        if (!png_ || !info_) throw std::runtime_error("libpng could not start");
        if (!png_open_core(png_, info_, &st_, &o_, f_, file_size_, &passes_)) throw std::runtime_error("PNG " + st_.error);
        next_ = 0;
        header = png_header(o_);
    }
    void close() {
        if (png_) png_destroy_read_struct(&png_, &info_, nullptr);
        png_ = nullptr, info_ = nullptr;
        if (f_) std::fclose(f_);
        f_ = nullptr;
    }
    std::string path_;
    uintmax_t file_size_;
    FILE* f_ = nullptr;
    png_structp png_ = nullptr;
    png_infop info_ = nullptr;
    ReadState st_;
    PngOut o_;
    int passes_ = 1;
    std::vector<unsigned char> buffer_;
    std::vector<png_bytep> row_at_;
};
}  // namespace

std::unique_ptr<RawRows> png_rows(const std::string& path, uintmax_t file_size) {
    auto rows = std::make_unique<PngRows>(path, file_size);
    if (rows->interlaced()) return nullptr;  // every pass covers every row: read whole
    return rows;
}

void write_png_file_rows(const std::string& path, int width, int height, int channels, int bits,
                         const std::function<void(int y0, int rows, float* out)>& fill, int level) {
    std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "wb"), &std::fclose);
    if (!f) throw std::runtime_error("cannot open for writing");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    // Freed however this ends (an exception from `fill`, a cancel, included).
    struct Guard {
        png_structp* png;
        png_infop* info;
        ~Guard() {
            if (*png) png_destroy_write_struct(png, info);
        }
    } guard{&png, &info};
    if (!png || !info) throw std::runtime_error("libpng could not start");
    const int stride = width * channels * (bits / 8);
    std::vector<unsigned char> row(stride);
    // Bands of 64 rows from `fill`: no whole-image buffer. volatile: read
    // after setjmp (GCC 10, the wheels' compiler, warns that it might be
    // clobbered otherwise).
    volatile const int band = std::min(64, height);
    std::vector<float> values(size_t(width) * channels * size_t(band));
    if (setjmp(png_jmpbuf(png))) throw std::runtime_error("libpng failed (disk full?)");
    png_init_io(png, f.get());
    png_set_compression_level(png, level);
    if (level <= 2) png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);  // one filter: no per-row search
    static const int kTypes[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                  PNG_COLOR_TYPE_RGB_ALPHA};
    png_set_IHDR(png, info, width, height, bits, kTypes[channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    if (bits == 16) png_set_gAMA(png, info, 1.0);  // 16-bit files hold linear data (the LUT)
    png_write_info(png, info);
    const float scale = bits == 8 ? 255.0f : 65535.0f;
    const int b = band;
    for (int y = 0; y < height; ++y) {
        if (y % b == 0) fill(y, std::min(b, height - y), values.data());
        const float* src = values.data() + size_t(y % b) * width * channels;
        for (int k = 0; k < width * channels; ++k) {
            const float v = std::fmin(std::fmax(src[k], 0.0f), 1.0f);
            const unsigned q = unsigned(std::lround(v * scale));
            if (bits == 8) {
                row[k] = static_cast<unsigned char>(q);
            } else {  // big-endian
                row[2 * k] = static_cast<unsigned char>(q >> 8);
                row[2 * k + 1] = static_cast<unsigned char>(q & 0xff);
            }
        }
        png_write_row(png, row.data());
    }
    png_write_end(png, nullptr);
    if (std::fflush(f.get()) != 0 || std::ferror(f.get())) throw std::runtime_error("write failed (disk full?)");
}

namespace {
void append_to_vector(png_structp png, png_bytep data, png_size_t length) {
    auto* out = static_cast<std::vector<unsigned char>*>(png_get_io_ptr(png));
    out->insert(out->end(), data, data + length);
}
void flush_nothing(png_structp) {}
}  // namespace

std::vector<unsigned char> encode_png8_memory(int width, int height, int channels, const unsigned char* values,
                                              int level) {
    std::vector<unsigned char> out;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        throw std::runtime_error("libpng could not start");
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        throw std::runtime_error("libpng failed");
    }
    png_set_write_fn(png, &out, &append_to_vector, &flush_nothing);
    png_set_compression_level(png, level);
    if (level <= 2) png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);  // one filter: no per-row search
    static const int kTypes[5] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                  PNG_COLOR_TYPE_RGB_ALPHA};
    png_set_IHDR(png, info, width, height, 8, kTypes[channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < height; ++y)
        png_write_row(png, const_cast<png_bytep>(values + size_t(y) * width * channels));
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return out;
}

}  // namespace iblbake::io::detail
