#include "iblbake/io/image_io.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "iblbake/math/color.h"

namespace iblbake::io {

namespace {
[[noreturn]] void fail(const std::string& path, const std::string& why) {
    std::string msg = why;
    std::replace(msg.begin(), msg.end(), '\n', ' ');
    throw std::runtime_error("cannot read '" + path + "': " + msg);
}
}  // namespace

LoadedImage read_image(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) fail(path, "no such file");
    if (std::filesystem::is_directory(path, ec)) fail(path, "is a directory");
    if (std::filesystem::file_size(path, ec) == 0) fail(path, "file is empty");
    auto in = OIIO::ImageInput::open(path);
    if (!in) fail(path, OIIO::geterror());
    const OIIO::ImageSpec spec = in->spec();
    const int dw = spec.width, dh = spec.height, nch = spec.nchannels;
    if (dw < 1 || dh < 1 || nch < 1 || spec.depth > 1) fail(path, "image has no pixels");
    std::vector<float> data(size_t(dw) * dh * nch);
    if (!in->read_image(0, 0, 0, nch, OIIO::TypeDesc::FLOAT, data.data())) fail(path, in->geterror());
    in->close();
    // The lat-long spans the display window; pixels outside the data window are 0.
    const int w = spec.full_width > 0 ? spec.full_width : dw, h = spec.full_height > 0 ? spec.full_height : dh;
    const int ox = spec.x - spec.full_x, oy = spec.y - spec.full_y;
    std::vector<float> raw;
    if (w == dw && h == dh && ox == 0 && oy == 0) {
        raw = std::move(data);
    } else {
        raw.assign(size_t(w) * h * nch, 0.0f);
        for (int y = 0; y < dh; ++y) {
            const int ty = y + oy;
            if (ty < 0 || ty >= h) continue;
            for (int x = 0; x < dw; ++x) {
                const int tx = x + ox;
                if (tx < 0 || tx >= w) continue;
                std::copy_n(&data[(size_t(y) * dw + x) * nch], nch, &raw[(size_t(ty) * w + tx) * nch]);
            }
        }
    }

    LoadedImage out;
    out.source_channels = nch;
    out.format = in->format_name();
    const std::string cs = spec.get_string_attribute("oiio:ColorSpace");
    const bool is_float = spec.format.is_floating_point();
    out.linearised = !is_float && cs != "linear" && cs != "Linear";
    out.image = Image(w, h);
    // Colour channels: RGB if there are three non-alpha channels, else grey.
    const int alpha = spec.alpha_channel;
    std::vector<int> colour;
    for (int c = 0; c < nch && colour.size() < 3; ++c)
        if (c != alpha) colour.push_back(c);
    if (colour.empty()) colour.push_back(0);
    if (colour.size() < 3) colour.assign(3, colour[0]);
    for (size_t p = 0; p < size_t(w) * h; ++p)
        for (int k = 0; k < 3; ++k) {
            float v = raw[p * nch + colour[k]];
            if (out.linearised) v = srgb_to_linear(v);
            out.image.pixels[p * 3 + k] = v;
        }
    return out;
}

namespace {
void write_generic(const std::string& path, const OIIO::ImageSpec& spec, const std::vector<float>& values) {
    auto out = OIIO::ImageOutput::create(path);
    if (!out) throw std::runtime_error("cannot write '" + path + "': " + OIIO::geterror());
    if (!out->open(path, spec)) throw std::runtime_error("cannot write '" + path + "': " + out->geterror());
    if (!out->write_image(OIIO::TypeDesc::FLOAT, values.data()))
        throw std::runtime_error("cannot write '" + path + "': " + out->geterror());
    if (!out->close()) throw std::runtime_error("cannot write '" + path + "': " + out->geterror());
}
}  // namespace

void write_exr(const std::string& path, int width, int height, int channels, const std::vector<float>& values,
               ExrPixel pixel) {
    OIIO::ImageSpec spec(width, height, channels,
                         pixel == ExrPixel::Half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
    if (channels == 4) spec.alpha_channel = 3;
    spec.attribute("compression", "zip");
    spec.attribute("oiio:ColorSpace", "linear");
    spec.attribute("DateTime", "");  // no time stamp: equal pixels, equal files
    write_generic(path, spec, values);
}

void write_png8(const std::string& path, int width, int height, int channels, const std::vector<float>& values) {
    OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT8);
    if (channels == 4) spec.alpha_channel = 3;
    // Values are already encoded: no colour conversion, no premultiplication.
    spec.attribute("oiio:UnassociatedAlpha", 1);
    write_generic(path, spec, values);
}

void write_png16(const std::string& path, int width, int height, int channels, const std::vector<float>& values) {
    OIIO::ImageSpec spec(width, height, channels, OIIO::TypeDesc::UINT16);
    spec.attribute("oiio:ColorSpace", "linear");
    write_generic(path, spec, values);
}

}  // namespace iblbake::io
