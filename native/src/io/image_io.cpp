#include "iblbake/io/image_io.h"

#include <dlfcn.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "iblbake/io/row_reader.h"
#include "iblbake/io/text.h"
#include "iblbake/math/color.h"
#include "raw_pixels.h"

namespace iblbake::io {

using detail::RawPixels;

void detail::fail_reading(const std::string& path, const std::string& why) {
    std::string msg = why;
    std::replace(msg.begin(), msg.end(), '\n', ' ');
    while (!msg.empty() && msg.back() == ' ') msg.pop_back();
    // A fuzzed header's bytes never reach the terminal raw.
    throw std::runtime_error("cannot read '" + printable(path) + "': " + printable(msg));
}

namespace {

std::string size_text(int64_t w, int64_t h) { return std::to_string(w) + " x " + std::to_string(h); }

// The OpenImageIO plugin: $IBLBAKE_OIIO_PLUGIN, else beside the binary that
// holds this code (the CLI, the Python module), else where the build put it.
struct Plugin {
    detail::IblbakeOiioRead read = nullptr;
    detail::IblbakeOiioFree release = nullptr;
    // Row by row (null in a plugin older than the streaming bake: files are read whole then).
    detail::IblbakeOiioOpenRows open_rows = nullptr;
    detail::IblbakeOiioReadRows read_rows = nullptr;
    detail::IblbakeOiioCloseRows close_rows = nullptr;
    std::string error;
};

const Plugin& plugin() {
    static Plugin p;
    static std::once_flag once;
    std::call_once(once, [] {
        std::vector<std::string> candidates;
        if (const char* env = std::getenv("IBLBAKE_OIIO_PLUGIN")) candidates.emplace_back(env);
        Dl_info info{};
        if (dladdr(reinterpret_cast<void*>(&plugin), &info) && info.dli_fname)
            candidates.push_back(
                (std::filesystem::path(info.dli_fname).parent_path() / "libiblbake_oiio.so").string());
#ifdef IBLBAKE_OIIO_PLUGIN_BUILD_PATH
        candidates.emplace_back(IBLBAKE_OIIO_PLUGIN_BUILD_PATH);
#endif
        for (const std::string& c : candidates) {
            std::error_code ec;
            if (!std::filesystem::is_regular_file(c, ec)) continue;
            void* h = dlopen(c.c_str(), RTLD_NOW | RTLD_LOCAL);
            if (!h) {
                p.error = dlerror();
                continue;
            }
            p.read = reinterpret_cast<detail::IblbakeOiioRead>(dlsym(h, "iblbake_oiio_read_v2"));
            p.release = reinterpret_cast<detail::IblbakeOiioFree>(dlsym(h, "iblbake_oiio_free"));
            if (p.read && p.release) {
                p.open_rows = reinterpret_cast<detail::IblbakeOiioOpenRows>(dlsym(h, "iblbake_oiio_open_rows_v3"));
                p.read_rows = reinterpret_cast<detail::IblbakeOiioReadRows>(dlsym(h, "iblbake_oiio_read_rows_v3"));
                p.close_rows = reinterpret_cast<detail::IblbakeOiioCloseRows>(dlsym(h, "iblbake_oiio_close_rows_v3"));
                if (!p.open_rows || !p.read_rows || !p.close_rows) p.open_rows = nullptr;
                return;
            }
            p.error = c + " is not iblbake's OpenImageIO plugin";
        }
        if (p.error.empty())
            p.error = "this build reads OpenEXR, PNG, JPEG and Radiance HDR itself, and other formats through its OpenImageIO "
                      "plugin (libiblbake_oiio.so), which it does not have (the self-contained wheels carry none): "
                      "convert the image to EXR";
    });
    return p;
}

// The most floats the plugin may allocate for a file of `file_size` bytes.
long long plugin_max_values(uintmax_t file_size) {
    return (long long)std::min<uintmax_t>(uintmax_t(kMaxSourcePixels) * 4,
                                          std::max<uintmax_t>(file_size, 1) * (kMaxExpansion / sizeof(float)));
}

// What the plugin says of an image, its pixels aside.
RawPixels header_of(const detail::IblbakeOiioImage& img) {
    RawPixels raw;
    raw.width = img.width;
    raw.height = img.height;
    raw.full_width = img.full_width;
    raw.full_height = img.full_height;
    raw.x_offset = img.x_offset;
    raw.y_offset = img.y_offset;
    raw.channels = img.channels;
    raw.alpha_channel = img.alpha_channel;
    raw.is_float = img.is_float != 0;
    raw.colorspace = img.colorspace;
    raw.format = img.format;
    return raw;
}

RawPixels read_with_plugin(const std::string& path, const std::string& format, uintmax_t file_size) {
    const Plugin& p = plugin();
    if (!p.read) detail::fail_reading(path, p.error);
    detail::IblbakeOiioImage img{};
    char error[512] = {0};
    const long long max_values = plugin_max_values(file_size);
    const int rc = p.read(path.c_str(), format.c_str(), kMaxSourceSide, max_values, &img, error, sizeof(error));
    if (rc == 2) detail::check_declared(img.width, img.height, img.channels, file_size);  // throws
    if (rc != 1) detail::fail_reading(path, error);
    RawPixels raw = header_of(img);
    raw.data.assign(img.data, img.data + size_t(img.width) * img.height * img.channels);
    p.release(img.data);
    return raw;
}

// How a file's channels become a texel's linear RGB: the same for every reader.
struct ColourRule {
    int channels = 3;
    int colour[3] = {0, 1, 2};  // RGB if there are three non-alpha channels, else grey
    int alpha = -1;             // a straight alpha that multiplies the colour, or -1
    bool linearised = false;    // integer values decoded from sRGB

    bool identity() const {
        return channels == 3 && colour[0] == 0 && colour[1] == 1 && colour[2] == 2 && alpha < 0 && !linearised;
    }
    // `texels` texels of `channels` floats from `in` to RGB in `out`.
    void apply(const float* in, size_t texels, float* out) const {
        for (size_t p = 0; p < texels; ++p)
            for (int k = 0; k < 3; ++k) {
                float v = in[p * channels + colour[k]];
                if (alpha >= 0) v *= in[p * channels + alpha];
                if (linearised) v = srgb_to_linear(v);
                out[p * 3 + k] = v;
            }
    }
};

// The rule of a file's header (its pixels are not looked at); what it chose in `warnings`.
ColourRule colour_rule(const RawPixels& r, std::vector<std::string>& warnings) {
    ColourRule rule;
    rule.channels = r.channels;
    rule.linearised = !r.is_float && r.colorspace != "linear" && r.colorspace != "Linear";
    std::vector<int> colour;
    for (int c = 0; c < r.channels && colour.size() < 3; ++c)
        if (c != r.alpha_channel) colour.push_back(c);
    if (colour.empty()) colour.push_back(0);
    if (colour.size() == 2)
        warnings.push_back("the file has 2 colour channels, neither grey nor RGB: baked as grey from the first");
    if (colour.size() < 3) colour.assign(3, colour[0]);
    std::copy(colour.begin(), colour.end(), rule.colour);
    // A world's texel is what Cycles shows: a straight alpha multiplies the
    // colour as stored (before an sRGB decode, as Cycles does for 8-bit
    // images); premultiplied colour (EXR, OpenImageIO's formats) is kept.
    if (r.straight_alpha && r.alpha_channel >= 0 && r.alpha_channel < r.channels) rule.alpha = r.alpha_channel;
    return rule;
}

// Display window, colour channels, sRGB decode: the same for every reader.
LoadedImage finish(RawPixels&& r) {
    LoadedImage out;
    out.warnings = std::move(r.warnings);
    const int dw = r.width, dh = r.height, nch = r.channels;
    int w = r.full_width > 0 ? r.full_width : dw, h = r.full_height > 0 ? r.full_height : dh;
    int ox = r.x_offset, oy = r.y_offset;
    if (w != dw || h != dh || ox != 0 || oy != 0) {
        // The lat-long spans the display window (outside the data, black) when
        // that holds the data window and is not far larger; else the data
        // window alone is baked: a 64 x 32 data window in a 24576 x 12288
        // display window must not cost gigabytes.
        const bool inside = ox >= 0 && oy >= 0 && int64_t(ox) + dw <= w && int64_t(oy) + dh <= h;
        const bool modest = int64_t(w) * h <= 4 * int64_t(dw) * dh;
        if (inside && modest) {
            check_source_size(w, h, "display window");
            out.warnings.push_back("the data window (" + size_text(dw, dh) + ") covers part of the display window (" +
                                   size_text(w, h) + "): the rest is baked as black");
        } else {
            out.warnings.push_back(
                std::string("the data window (") + size_text(dw, dh) + " at " + std::to_string(ox) + ", " +
                std::to_string(oy) + ") " + (inside ? "is far smaller than" : "lies outside") +
                " the display window (" + size_text(w, h) + "): the data window alone is baked");
            w = dw, h = dh, ox = oy = 0;
        }
    }
    FloatBuffer raw;
    if (w == dw && h == dh && ox == 0 && oy == 0) {
        raw = std::move(r.data);
    } else {  // the lat-long spans the display window; pixels outside the data window are 0
        raw.assign(size_t(w) * h * nch, 0.0f);
        for (int y = 0; y < dh; ++y) {
            const int ty = y + oy;
            if (ty < 0 || ty >= h) continue;
            for (int x = 0; x < dw; ++x) {
                const int tx = x + ox;
                if (tx < 0 || tx >= w) continue;
                std::copy_n(&r.data[(size_t(y) * dw + x) * nch], nch, &raw[(size_t(ty) * w + tx) * nch]);
            }
        }
    }
    out.source_channels = nch;
    out.format = r.format;
    const ColourRule rule = colour_rule(r, out.warnings);
    out.linearised = rule.linearised;
    if (rule.identity()) {
        // Linear RGB already in Image's layout (an EXR's R, G, B): kept, not copied.
        out.image.width = w;
        out.image.height = h;
        out.image.pixels = std::move(raw);
        return out;
    }
    out.image = Image(w, h);
    rule.apply(raw.data(), size_t(w) * h, out.image.pixels.data());
    return out;
}

void check_size(const std::string& path, int width, int height, int channels, size_t values) {
    if (width < 1 || height < 1 || channels < 1 || channels > 4 || values != size_t(width) * height * channels)
        throw std::invalid_argument("cannot write '" + path + "': buffer does not match its size");
}

}  // namespace

namespace {

// The format a file's first bytes name ("" when they name none of these).
std::string sniff(const unsigned char* b, size_t n) {
    auto starts = [&](const char* magic, size_t len) { return n >= len && std::memcmp(b, magic, len) == 0; };
    if (starts("\x89PNG\r\n\x1a\n", 8)) return "png";
    if (starts("\xff\xd8\xff", 3)) return "jpeg";
    if (starts("#?RADIANCE", 10) || starts("#?RGBE", 6)) return "hdr";
    if (starts("II*\0", 4) || starts("MM\0*", 4) || starts("II+\0", 4) || starts("MM\0+", 4)) return "tiff";
    if (starts("BM", 2)) return "bmp";
    if (starts("8BPS", 4)) return "psd";
    if (starts("DDS ", 4)) return "dds";
    if (starts("RIFF", 4) && n >= 12 && std::memcmp(b + 8, "WEBP", 4) == 0) return "webp";
    if (n >= 2 && b[0] == 'P' && std::strchr("123456Ff", b[1]) && b[1] != 0) return "pnm";
    return "";
}

// The format an extension names, for formats with no magic number (Targa) or an unknown one.
std::string format_of_extension(const std::string& path) {
    static const std::map<std::string, std::string> kFormats = {
        {"exr", "openexr"}, {"hdr", "hdr"},   {"rgbe", "hdr"},   {"pic", "hdr"},  {"png", "png"},
        {"jpg", "jpeg"},    {"jpeg", "jpeg"}, {"jpe", "jpeg"},   {"jfif", "jpeg"}, {"tif", "tiff"},
        {"tiff", "tiff"},   {"tga", "targa"}, {"tpic", "targa"}, {"bmp", "bmp"},  {"psd", "psd"},
        {"dds", "dds"},     {"webp", "webp"}, {"pfm", "pnm"},    {"ppm", "pnm"},  {"pgm", "pnm"},
        {"pnm", "pnm"}};
    std::string ext = std::filesystem::path(path).extension().string();
    if (!ext.empty()) ext.erase(0, 1);
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    const auto it = kFormats.find(ext);
    return it == kFormats.end() ? std::string() : it->second;
}

// A JPEG ends with its end-of-image marker (FF D9), which entropy-coded data
// never holds: without one in the last bytes the file was cut, and libjpeg
// would fill the missing rows with grey after a mere warning.
bool jpeg_has_end(std::FILE* f, uintmax_t size) {
    const long tail = long(std::min<uintmax_t>(size, 4096));
    std::vector<unsigned char> b(size_t(tail), 0);
    if (std::fseek(f, -tail, SEEK_END) != 0 || std::fread(b.data(), 1, b.size(), f) != b.size()) return false;
    for (size_t i = 0; i + 1 < b.size(); ++i)
        if (b[i] == 0xFF && b[i + 1] == 0xD9) return true;
    return false;
}

// The format of an open file: its first bytes, else its extension ("" for none).
std::string format_of(std::FILE* f, const std::string& path) {
    unsigned char head[16] = {0};
    std::rewind(f);
    const size_t n = std::fread(head, 1, sizeof(head), f);
    if (n >= 4 && std::memcmp(head, "\x76\x2f\x31\x01", 4) == 0) return "openexr";
    const std::string sniffed = sniff(head, n);
    return sniffed.empty() ? format_of_extension(path) : sniffed;
}

// A Radiance file whose header says FORMAT=32-bit_rle_xyze.
bool radiance_is_xyz(std::FILE* f) {
    char head[1024] = {0};
    std::rewind(f);
    const size_t n = std::fread(head, 1, sizeof(head) - 1, f);
    const std::string text(head, n);
    const size_t end = text.find("\n\n");
    return text.substr(0, end).find("FORMAT=32-bit_rle_xyze") != std::string::npos;
}

bool is_jpeg_magic(std::FILE* f) {
    unsigned char head[3] = {0};
    std::rewind(f);
    return std::fread(head, 1, 3, f) == 3 && sniff(head, 3) == "jpeg";
}

}  // namespace

std::string image_format(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) return format_of_extension(path);
    // Without blocking: a regular file's open never waits.
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    return f ? format_of(f.get(), path) : format_of_extension(path);
}

bool reads_format(const std::string& format) {
    if (format == "openexr" || format == "png" || format == "jpeg" || format == "hdr") return true;
    return !format.empty() && plugin().read != nullptr;
}

void check_source_size(int64_t width, int64_t height, const std::string& what) {
    if (width < 1 || height < 1) throw std::runtime_error(what + " has no pixels (" + size_text(width, height) + ")");
    if (width > kMaxSourceSide || height > kMaxSourceSide || width * height > kMaxSourcePixels)
        throw std::runtime_error(what + " is " + size_text(width, height) + ": larger than the maximum of " +
                                 std::to_string(kMaxSourcePixels >> 20) + " Mpixels (32768 x 16384) and " +
                                 std::to_string(kMaxSourceSide) + " on a side");
}

void detail::check_declared(int64_t width, int64_t height, int channels, uintmax_t file_size) {
    check_source_size(width, height);
    const uintmax_t bytes = uintmax_t(width) * uintmax_t(height) * uintmax_t(std::max(channels, 1)) * sizeof(float);
    if (bytes / uintmax_t(kMaxExpansion) > file_size)
        throw std::runtime_error("the header declares " + size_text(width, height) + " pixels, but the file holds only " +
                                 std::to_string(file_size) + " bytes: truncated or damaged");
}

namespace {
// The format of the file at `path` and its size, after the checks every
// read makes first; throws read_image's error for what it refuses.
std::string checked_format(const std::string& path, uintmax_t& size) {
    namespace fs = std::filesystem;
    std::error_code ec;
    // stat() before open(): a FIFO would block the open, a device never ends.
    const fs::file_status st = fs::status(path, ec);
    if (st.type() == fs::file_type::not_found) detail::fail_reading(path, "no such file");
    if (ec) detail::fail_reading(path, ec.message());
    if (st.type() == fs::file_type::directory) detail::fail_reading(path, "is a directory");
    if (st.type() != fs::file_type::regular) {
        const char* kind = st.type() == fs::file_type::fifo        ? "a FIFO"
                           : st.type() == fs::file_type::character ? "a character device"
                           : st.type() == fs::file_type::block     ? "a block device"
                           : st.type() == fs::file_type::socket    ? "a socket"
                                                                   : "not a file";
        detail::fail_reading(path, std::string("is not a regular file (") + kind + ")");
    }
    size = fs::file_size(path, ec);
    if (ec) detail::fail_reading(path, ec.message());
    if (size == 0) detail::fail_reading(path, "file is empty");
    std::string format;
    {
        std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
        if (!f) detail::fail_reading(path, std::strerror(errno));
        format = format_of(f.get(), path);
        if (format.empty())
            detail::fail_reading(path, "not an image format iblbake reads (its first bytes are not EXR, PNG, JPEG, Radiance HDR, "
                       "TIFF, ... and its extension names none)");
        if (format == "jpeg" && is_jpeg_magic(f.get()) && !jpeg_has_end(f.get(), size))
            detail::fail_reading(path, "JPEG file is truncated (no end-of-image marker)");
        if (format == "hdr" && radiance_is_xyz(f.get()))
            detail::fail_reading(path, "a Radiance file in CIE XYZ (FORMAT=32-bit_rle_xyze), which iblbake does not read: "
                       "convert it to RGBE or EXR");
        if (format == "dds")
            detail::fail_reading(path, "a DDS texture (a GPU container, as iblbake's own exports are), not a lat-long source: "
                       "bake from the EXR or HDR it was made from");
    }
    return format;
}

// A file OpenImageIO's plugin reads by scanlines.
class PluginRows final : public detail::RawRows {
public:
    PluginRows(const Plugin& p, void* handle, const detail::IblbakeOiioImage& h) : plugin_(p), handle_(handle) {
        header = header_of(h);
    }
    ~PluginRows() override { plugin_.close_rows(handle_); }
    PluginRows(const PluginRows&) = delete;
    PluginRows& operator=(const PluginRows&) = delete;
    // Two megabytes of floats a band, at most 128 rows: the decoders read scanline after scanline.
    int preferred_band() const override { return std::clamp(int((1 << 19) / std::max(header.width, 1)), 16, 128); }
    void read(int y0, int rows, float* out) override {
        char error[512] = {0};
        if (plugin_.read_rows(handle_, y0, rows, out, error, sizeof(error)) != 1) throw std::runtime_error(error);
    }

private:
    const Plugin& plugin_;
    void* handle_;
};

// A reader's rows as linear RGB: read_image's finishing, row by row.
class FinishedRows final : public RowReader {
public:
    FinishedRows(std::unique_ptr<detail::RawRows> raw, std::string path)
        : raw_(std::move(raw)), path_(std::move(path)) {
        rule_ = colour_rule(raw_->header, warnings_);
    }
    int width() const override { return raw_->header.width; }
    int height() const override { return raw_->header.height; }
    const std::vector<std::string>& warnings() const override { return warnings_; }
    bool linearised() const override { return rule_.linearised; }
    int preferred_band() const override { return raw_->preferred_band(); }
    void read(int y0, int rows, float* out) override {
        if (y0 < 0 || rows < 0 || y0 + rows > height()) throw std::out_of_range("rows outside the image");
        if (rows == 0) return;
        float* dst = out;
        if (!rule_.identity()) {
            scratch_.resize(size_t(rows) * width() * rule_.channels);
            dst = scratch_.data();
        }
        try {
            raw_->read(y0, rows, dst);
        } catch (const std::bad_alloc&) {
            detail::fail_reading(path_, "out of memory while reading");
        } catch (const std::exception& e) {
            detail::fail_reading(path_, e.what());
        }
        if (dst != out) rule_.apply(dst, size_t(rows) * width(), out);
    }

private:
    std::unique_ptr<detail::RawRows> raw_;
    std::string path_;
    ColourRule rule_;
    std::vector<std::string> warnings_;
    std::vector<float> scratch_;
};

// The plugin's rows of a PNM/PFM file, or null when it is
// read whole. Other formats are read whole: OpenImageIO's scanline reads of
// TIFF refuse some files its whole-image read takes (a fuzzed strip layout),
// and the rows must be read_image's.
std::unique_ptr<detail::RawRows> plugin_rows(const std::string& path, const std::string& format, uintmax_t size) {
    const Plugin& p = plugin();
    if (!p.open_rows || format != "pnm") return nullptr;
    detail::IblbakeOiioImage header{};
    char error[512] = {0};
    int rc = 0;
    void* handle = p.open_rows(path.c_str(), format.c_str(), kMaxSourceSide, plugin_max_values(size), &header, &rc,
                               error, sizeof(error));
    if (rc == 2) detail::check_declared(header.width, header.height, header.channels, size);  // throws
    if (rc == 3) return nullptr;
    if (!handle) throw std::runtime_error(error);
    return std::make_unique<PluginRows>(p, handle, header);  // closes the handle from here on
}
}  // namespace

std::unique_ptr<RowReader> open_rows(const std::string& path) {
    uintmax_t size = 0;
    const std::string format = checked_format(path, size);
    if (format == "openexr") return std::make_unique<ExrRowReader>(path);
    try {
        std::unique_ptr<detail::RawRows> raw = format == "png"    ? detail::png_rows(path, size)
                                               : format == "jpeg" ? detail::jpeg_rows(path, size)
                                               : format == "hdr"  ? detail::hdr_rows(path, size)
                                                                  : plugin_rows(path, format, size);
        if (!raw) return nullptr;
        check_source_size(raw->header.width, raw->header.height);
        detail::check_declared(raw->header.width, raw->header.height, raw->header.channels, size);
        return std::make_unique<FinishedRows>(std::move(raw), path);
    } catch (const std::bad_alloc&) {
        detail::fail_reading(path, "out of memory while reading");
    } catch (const std::runtime_error& e) {
        if (std::string(e.what()).rfind("cannot read '", 0) == 0) throw;  // already names the file
        detail::fail_reading(path, e.what());
    }
}

detail::RawPixels detail::read_all_rows(RawRows& rows, const std::function<void(double)>& progress) {
    RawPixels out = rows.header;
    const size_t row_values = size_t(out.width) * out.channels;
    out.data = FloatBuffer(row_values * size_t(out.height));
    const int band = std::max(rows.preferred_band(), 1);
    for (int y0 = 0; y0 < out.height; y0 += band) {
        const int n = std::min(band, out.height - y0);
        rows.read(y0, n, out.data.data() + size_t(y0) * row_values);
        if (progress) progress(double(y0 + n) / out.height);
    }
    return out;
}

LoadedImage read_image(const std::string& path, const ReadProgress& progress) {
    uintmax_t size = 0;
    const std::string format = checked_format(path, size);
    try {
        if (format == "openexr") return finish(detail::read_exr(path, size, progress));
        if (format == "png") return finish(detail::read_png(path, size, progress));
        LoadedImage out;
        std::unique_ptr<detail::RawRows> hdr = format == "hdr" ? detail::hdr_rows(path, size) : nullptr;
        if (format == "jpeg") {
            out = finish(detail::read_jpeg(path, size));
        } else if (hdr) {
            out = finish(detail::read_all_rows(*hdr, progress));
        } else {  // other formats, and a Radiance file stored turned
            if (format == "tiff") detail::check_tiff_complete(path, size);
            out = finish(read_with_plugin(path, format, size));
        }
        if (progress) progress(1.0);
        return out;
    } catch (const std::bad_alloc&) {
        detail::fail_reading(path, "out of memory while reading");
    } catch (const std::runtime_error& e) {
        const std::string prefix = "cannot read '";
        if (std::string(e.what()).rfind(prefix, 0) == 0) throw;  // already names the file
        detail::fail_reading(path, e.what());
    } catch (const std::exception& e) {
        detail::fail_reading(path, e.what());
    }
}

namespace {
// A whole interleaved buffer handed to a banded writer, rows y0 .. y0 + rows - 1 at a time.
std::function<void(int, int, float*)> rows_of(FloatSpan values, int width, int channels) {
    const size_t row = size_t(width) * channels;
    return [values, row](int y0, int rows, float* out) {
        std::copy(values.data + size_t(y0) * row, values.data + size_t(y0 + rows) * row, out);
    };
}

using Fill = std::function<void(int, int, float*)>;

// Checks the size, runs `write` with `fill` and names the file in any error
// of the writer; an exception from `fill` itself (a cancel) passes unchanged.
template <typename Fn>
void write_checked(const std::string& path, int width, int height, int channels, size_t values, const Fill& fill,
                   Fn&& write) {
    check_size(path, width, height, channels, values);
    bool fill_threw = false;
    const Fill guarded = [&](int y0, int rows, float* out) {
        try {
            fill(y0, rows, out);
        } catch (...) {
            fill_threw = true;
            throw;
        }
    };
    try {
        write(guarded);
    } catch (const std::exception& e) {
        if (fill_threw) throw;
        throw std::runtime_error("cannot write '" + printable(path) + "': " + e.what());
    }
}
}  // namespace

void write_exr(const std::string& path, int width, int height, int channels, FloatSpan values,
               ExrPixel pixel) {
    write_checked(path, width, height, channels, values.size, rows_of(values, width, channels), [&](const Fill& f) {
        detail::write_exr_file_rows(path, width, height, channels, pixel == ExrPixel::Half, f);
    });
}

void write_exr_rows(const std::string& path, int width, int height, int channels, ExrPixel pixel,
                    const std::function<void(int y0, int rows, float* out)>& fill) {
    write_checked(path, width, height, channels, size_t(width) * height * channels, fill, [&](const Fill& f) {
        detail::write_exr_file_rows(path, width, height, channels, pixel == ExrPixel::Half, f);
    });
}

void write_png8(const std::string& path, int width, int height, int channels, FloatSpan values) {
    write_checked(path, width, height, channels, values.size, rows_of(values, width, channels),
                  [&](const Fill& f) { detail::write_png_file_rows(path, width, height, channels, 8, f); });
}

void write_png8_rows(const std::string& path, int width, int height, int channels,
                     const std::function<void(int y0, int rows, float* out)>& fill) {
    write_checked(path, width, height, channels, size_t(width) * height * channels, fill,
                  [&](const Fill& f) { detail::write_png_file_rows(path, width, height, channels, 8, f); });
}

void write_png16(const std::string& path, int width, int height, int channels, FloatSpan values) {
    write_checked(path, width, height, channels, values.size, rows_of(values, width, channels),
                  [&](const Fill& f) { detail::write_png_file_rows(path, width, height, channels, 16, f); });
}

}  // namespace iblbake::io
