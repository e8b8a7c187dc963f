#include "iblbake/io/image_io.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "iblbake/math/color.h"
#include "raw_pixels.h"

namespace iblbake::io {

using detail::RawPixels;

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& why) {
    std::string msg = why;
    std::replace(msg.begin(), msg.end(), '\n', ' ');
    throw std::runtime_error("cannot read '" + path + "': " + msg);
}

// The OpenImageIO plugin: $IBLBAKE_OIIO_PLUGIN, else beside the binary that
// holds this code (the CLI, the Python module), else where the build put it.
struct Plugin {
    detail::IblbakeOiioRead read = nullptr;
    detail::IblbakeOiioFree release = nullptr;
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
            p.read = reinterpret_cast<detail::IblbakeOiioRead>(dlsym(h, "iblbake_oiio_read"));
            p.release = reinterpret_cast<detail::IblbakeOiioFree>(dlsym(h, "iblbake_oiio_free"));
            if (p.read && p.release) return;
            p.error = c + " is not iblbake's OpenImageIO plugin";
        }
        if (p.error.empty()) p.error = "libiblbake_oiio.so (the OpenImageIO reader for formats other than EXR) not found";
    });
    return p;
}

RawPixels read_with_plugin(const std::string& path) {
    const Plugin& p = plugin();
    if (!p.read) fail(path, p.error);
    detail::IblbakeOiioImage img{};
    char error[512] = {0};
    if (!p.read(path.c_str(), &img, error, sizeof(error))) fail(path, error);
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
    raw.data.assign(img.data, img.data + size_t(img.width) * img.height * img.channels);
    p.release(img.data);
    return raw;
}

// Display window, colour channels, sRGB decode: the same for every reader.
LoadedImage finish(RawPixels&& r) {
    const int dw = r.width, dh = r.height, nch = r.channels;
    const int w = r.full_width > 0 ? r.full_width : dw, h = r.full_height > 0 ? r.full_height : dh;
    const int ox = r.x_offset, oy = r.y_offset;
    std::vector<float> raw;
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
    LoadedImage out;
    out.source_channels = nch;
    out.format = r.format;
    out.linearised = !r.is_float && r.colorspace != "linear" && r.colorspace != "Linear";
    // Colour channels: RGB if there are three non-alpha channels, else grey.
    std::vector<int> colour;
    for (int c = 0; c < nch && colour.size() < 3; ++c)
        if (c != r.alpha_channel) colour.push_back(c);
    if (colour.empty()) colour.push_back(0);
    if (colour.size() < 3) colour.assign(3, colour[0]);
    if (nch == 3 && colour == std::vector<int>{0, 1, 2} && !out.linearised) {
        // Linear RGB already in Image's layout (an EXR's R, G, B): kept, not copied.
        out.image.width = w;
        out.image.height = h;
        out.image.pixels = std::move(raw);
        return out;
    }
    out.image = Image(w, h);
    for (size_t p = 0; p < size_t(w) * h; ++p)
        for (int k = 0; k < 3; ++k) {
            float v = raw[p * nch + colour[k]];
            if (out.linearised) v = srgb_to_linear(v);
            out.image.pixels[p * 3 + k] = v;
        }
    return out;
}

void check_size(const std::string& path, int width, int height, int channels, size_t values) {
    if (width < 1 || height < 1 || channels < 1 || channels > 4 || values != size_t(width) * height * channels)
        throw std::invalid_argument("cannot write '" + path + "': buffer does not match its size");
}

}  // namespace

LoadedImage read_image(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) fail(path, "no such file");
    if (std::filesystem::is_directory(path, ec)) fail(path, "is a directory");
    if (std::filesystem::file_size(path, ec) == 0) fail(path, "file is empty");
    if (detail::is_exr(path)) {
        try {
            return finish(detail::read_exr(path));
        } catch (const std::exception& e) {
            fail(path, e.what());
        }
    }
    return finish(read_with_plugin(path));
}

namespace {
// A whole interleaved buffer handed to a banded writer, rows y0 .. y0 + rows - 1 at a time.
std::function<void(int, int, float*)> rows_of(const std::vector<float>& values, int width, int channels) {
    const size_t row = size_t(width) * channels;
    return [&values, row](int y0, int rows, float* out) {
        std::copy(values.begin() + size_t(y0) * row, values.begin() + size_t(y0 + rows) * row, out);
    };
}

// Checks the buffer, runs `write`, and names the file in any error.
template <typename Fn>
void write_checked(const std::string& path, int width, int height, int channels, size_t values, Fn&& write) {
    check_size(path, width, height, channels, values);
    try {
        write();
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot write '" + path + "': " + e.what());
    }
}
}  // namespace

void write_exr(const std::string& path, int width, int height, int channels, const std::vector<float>& values,
               ExrPixel pixel) {
    write_checked(path, width, height, channels, values.size(), [&] {
        detail::write_exr_file_rows(path, width, height, channels, pixel == ExrPixel::Half,
                                    rows_of(values, width, channels));
    });
}

void write_exr_rows(const std::string& path, int width, int height, int channels, ExrPixel pixel,
                    const std::function<void(int y0, int rows, float* out)>& fill) {
    write_checked(path, width, height, channels, size_t(width) * height * channels, [&] {
        detail::write_exr_file_rows(path, width, height, channels, pixel == ExrPixel::Half, fill);
    });
}

void write_png8(const std::string& path, int width, int height, int channels, const std::vector<float>& values) {
    write_checked(path, width, height, channels, values.size(),
                  [&] { detail::write_png_file_rows(path, width, height, channels, 8, rows_of(values, width, channels)); });
}

void write_png8_rows(const std::string& path, int width, int height, int channels,
                     const std::function<void(int y0, int rows, float* out)>& fill) {
    write_checked(path, width, height, channels, size_t(width) * height * channels,
                  [&] { detail::write_png_file_rows(path, width, height, channels, 8, fill); });
}

void write_png16(const std::string& path, int width, int height, int channels, const std::vector<float>& values) {
    write_checked(path, width, height, channels, values.size(),
                  [&] { detail::write_png_file_rows(path, width, height, channels, 16, rows_of(values, width, channels)); });
}

}  // namespace iblbake::io
