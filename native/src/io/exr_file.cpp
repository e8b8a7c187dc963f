// EXR files through OpenEXR itself (no OpenImageIO: a bake of EXR files
// loads a handful of libraries, not hundreds).
#include <Imath/ImathBox.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfInputPart.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <OpenEXR/ImfTestFile.h>
#include <OpenEXR/ImfThreading.h>
#include <OpenEXR/IlmThreadPool.h>
#include <OpenEXR/OpenEXRConfig.h>
#include <Imath/half.h>
#if OPENEXR_VERSION_MAJOR > 3 || (OPENEXR_VERSION_MAJOR == 3 && OPENEXR_VERSION_MINOR >= 3)
#include <OpenEXR/ImfContextInit.h>
#define IBLBAKE_EXR_CONTEXT_INIT 1
#endif

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>
#include <mutex>
#include <map>
#include <string>
#include <stdexcept>
#include <vector>
#include <thread>

#include <libdeflate.h>

#include "iblbake/io/deflate.h"
#include "iblbake/io/image_io.h"
#include "iblbake/io/row_reader.h"
#include "iblbake/io/text.h"
#include "iblbake/math/half.h"
#include "exr_zip.h"
#include "raw_pixels.h"

namespace iblbake::io::detail {

bool is_exr(const std::string& path) { return Imf::isOpenExrFile(path.c_str()); }

namespace {

// OpenEXR's own thread pool, one thread per core: line blocks of a file are
// decompressed in parallel (an 8K zip EXR reads about twice as fast).
int exr_threads() {
    static std::once_flag once;
    static int n = 1;
    std::call_once(once, [] {
        n = int(std::max(1u, std::thread::hardware_concurrency()));
        Imf::setGlobalThreadCount(n);
    });
    return n;
}

// What the readers pass OpenEXR as their thread count, which in OpenEXR 3.1
// sets how many line buffers a file keeps in flight (twice the number):
// with one (two buffers) both threads of the pool above still decode at
// once, while every further buffer only holds memory (each DWA buffer keeps
// its own tables: 5 MB more at the peak of a 2K bake with the default two,
// 54 MB for an 8K source; reading was no faster, DWAB or ZIP).
int exr_line_buffer_threads() {
    exr_threads();  // the pool that does the work
    return 1;
}

}  // namespace

namespace {
// OpenEXR's own header check refuses larger windows and tiles, before it
// sizes its chunk tables from them.
void limit_exr_sizes() {
    static std::once_flag once;
    std::call_once(once, [] {
        Imf::Header::setMaxImageSize(int(kMaxSourceSide), int(kMaxSourceSide));
        Imf::Header::setMaxTileSize(8192, 8192);
    });
}

// OpenEXR 3.3 and later read through OpenEXRCore, whose default error
// handler prints every error to stderr as well as failing the call: the
// failure reaches the caller as an exception, the print would be a second,
// raw line next to iblbake's one clear error. Older versions never print.
#ifdef IBLBAKE_EXR_CONTEXT_INIT
void quiet_exr_error(exr_const_context_t, exr_result_t, const char*) {}
#endif

std::unique_ptr<Imf::InputFile> open_exr(const std::string& path) {
#ifdef IBLBAKE_EXR_CONTEXT_INIT
    Imf::ContextInitializer init;
    init.setErrorHandler(&quiet_exr_error);
    return std::make_unique<Imf::InputFile>(path.c_str(), init, exr_line_buffer_threads());
#else
    return std::make_unique<Imf::InputFile>(path.c_str(), exr_line_buffer_threads());
#endif
}

// A fuzzed header's name shown in a message: printable, at most 40 bytes of it.
std::string shown_name(const std::string& name) {
    return name.size() <= 40 ? name : name.substr(0, 40) + "...";
}

int checked_int(int64_t v, const char* what) {
    if (v < -(int64_t(1) << 30) || v > (int64_t(1) << 30)) throw std::runtime_error(std::string(what) + " out of range");
    return int(v);
}
}  // namespace

// OpenEXR 3.1 allocates an attribute's declared size before reading it (a
// fuzzed 819-byte file asked for 1.9 GB): every attribute of every header
// must fit in the file before OpenEXR sees it.
void check_exr_headers(const std::string& path, uintmax_t file_size) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!f) throw std::runtime_error("cannot open the file");
    unsigned char head[8];
    if (std::fread(head, 1, 8, f.get()) != 8) throw std::runtime_error("file is truncated (no header)");
    const bool multipart = head[5] & 0x10;  // version flags: 0x1000 is bit 4 of the second byte
    uint64_t pos = 8;
    auto read_name = [&](std::string& out) {  // up to 255 bytes and a NUL
        out.clear();
        for (;;) {
            const int c = std::fgetc(f.get());
            if (c == EOF) throw std::runtime_error("header is truncated");
            ++pos;
            if (c == 0) return;
            out += char(c);
            if (out.size() > 255) throw std::runtime_error("header is damaged (a name longer than 255 bytes)");
        }
    };
    std::string name, type;
    for (int header = 0; header < 1 << 16; ++header) {
        int attributes = 0;
        for (;; ++attributes) {
            read_name(name);
            if (name.empty()) break;
            read_name(type);
            unsigned char b[4];
            if (std::fread(b, 1, 4, f.get()) != 4) throw std::runtime_error("header is truncated");
            pos += 4;
            const int32_t size = int32_t(uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24);
            if (size < 0 || pos + uint64_t(size) > file_size)
                throw std::runtime_error("header is damaged: attribute '" + shown_name(name) + "' declares " + std::to_string(size) +
                                         " bytes, the file holds " + std::to_string(file_size));
            if (std::fseek(f.get(), long(size), SEEK_CUR) != 0) throw std::runtime_error("header is truncated");
            pos += uint64_t(size);
        }
        if (!multipart || attributes == 0) return;  // a multi-part file's headers end with an empty one
    }
}

namespace {
// The scan lines one compressed block of a file holds.
int lines_per_block(Imf::Compression c) {
    switch (c) {
        case Imf::NO_COMPRESSION:
        case Imf::RLE_COMPRESSION:
        case Imf::ZIPS_COMPRESSION: return 1;
        case Imf::ZIP_COMPRESSION:
        case Imf::PXR24_COMPRESSION: return 16;
        case Imf::DWAB_COMPRESSION: return 256;
        default: return 32;  // PIZ, B44, B44A, DWAA
    }
}

// The rows of an EXR read in bands, progress reported after each: a band
// holds a block per thread of the pool (at least 128 rows), so the threads
// still decode side by side.
template <typename ReadRows>
void read_in_bands(int y_min, int y_max, Imf::Compression compression, const std::function<void(double)>& progress,
                   ReadRows&& read_rows) {
    if (!progress) {
        read_rows(y_min, y_max);
        return;
    }
    const int band = std::max(128, lines_per_block(compression) * exr_threads());
    const double rows = double(y_max) - y_min + 1;
    for (int y = y_min; y <= y_max;) {
        const int last = int(std::min<int64_t>(int64_t(y) + band - 1, y_max));
        read_rows(y, last);
        progress((double(last) - y_min + 1) / rows);
        if (last == y_max) break;
        y = last + 1;
    }
}

// The channels a part's radiance is read from: R, G, B; else a layer's
// R, G, B (Blender's multilayer `ViewLayer.Combined.R`, a pass's
// `diffuse.R`) or lowercase r, g, b; else Y (grey, warned); else those of
// R, G, B it has (grey, as issue 15 baked two). Alpha, depth and other
// channels are never radiance. `why` says what a part without these holds.
struct ChannelChoice {
    std::vector<std::string> names;  // R, G, B (or a layer's), some of R, G, B, or Y; empty: none
    std::string layer;               // "" for plain R, G, B
};

std::string listed(const std::vector<std::string>& v, size_t most = 4) {
    std::string s;
    for (size_t i = 0; i < v.size() && i < most; ++i) s += (i ? ", '" : "'") + shown_name(v[i]) + "'";
    if (v.size() > most) s += " and " + std::to_string(v.size() - most) + " more";
    return s;
}

ChannelChoice choose_channels(const Imf::ChannelList& ch, std::string& why) {
    std::vector<std::string> all;
    for (auto it = ch.begin(); it != ch.end(); ++it) all.emplace_back(it.name());
    auto has = [&](const std::string& n) { return ch.findChannel(n.c_str()) != nullptr; };
    if (has("R") && has("G") && has("B")) return {{"R", "G", "B"}, ""};
    // Layers (everything before a channel's last dot) holding all of R, G, B or r, g, b.
    std::vector<std::string> layers;
    std::map<std::string, std::vector<std::string>> names;
    for (const std::string& n : all) {
        const size_t dot = n.rfind('.');
        const std::string layer = dot == std::string::npos ? "" : n.substr(0, dot);
        const std::string prefix = dot == std::string::npos ? "" : layer + ".";
        for (const char* rgb : {"RGB", "rgb"})
            if (n == prefix + rgb[0] && has(prefix + rgb[1]) && has(prefix + rgb[2])) {
                layers.push_back(layer);
                names[layer] = {prefix + rgb[0], prefix + rgb[1], prefix + rgb[2]};
            }
    }
    const auto combined = std::find_if(layers.begin(), layers.end(), [](const std::string& l) {
        return l == "Combined" || (l.size() > 9 && l.compare(l.size() - 9, 9, ".Combined") == 0);
    });
    if (combined != layers.end()) return {names[*combined], *combined};
    if (layers.size() == 1) return {names[layers[0]], layers[0]};
    if (layers.size() > 1) {
        why = "it holds the colour layers " + listed(layers) + " and no plain R, G, B or Combined layer to choose";
        return {};
    }
    if (has("Y")) return {{"Y"}, ""};
    // Some of R, G, B (issue 15: two colour channels bake as grey, warned).
    std::vector<std::string> some;
    for (const char* n : {"R", "G", "B"})
        if (has(n)) some.emplace_back(n);
    if (!some.empty()) return {some, ""};
    why = "it has no colour channels (R, G, B, a layer's R, G, B, or Y), only " + listed(all) +
          " (alpha, depth and other passes are not radiance)";
    return {};
}

// Whether the channels read are three, each HALF in the file: then they
// are read as interleaved halves (OpenEXR's SIMD path for an RGB half frame
// buffer) and made floats by F16C (halves_to_floats), not by OpenEXR's
// conversion, which goes value by value (a tenth of a 16K bake's CPU).
bool three_half_channels(const Imf::ChannelList& ch, const std::vector<std::string>& names) {
    if (names.size() != 3) return false;
    for (const std::string& n : names)
        if (ch[n.c_str()].type != Imf::HALF) return false;
    return true;
}

// The slices that put rows first_y.. of a data window starting at column
// min_x, `width` wide, as interleaved RGB halves at `halves`: the upper half
// of those rows' float storage, which halves_to_floats then fills in place.
void insert_half_slices(Imf::FrameBuffer& fb, const std::vector<std::string>& names, char* halves, int min_x,
                        int first_y, int width) {
    const size_t xs = 3 * sizeof(uint16_t), ys = xs * size_t(width);
    char* base = halves - min_x * ptrdiff_t(xs) - first_y * ptrdiff_t(ys);
    for (int c = 0; c < 3; ++c) fb.insert(names[c], Imf::Slice(Imf::HALF, base + c * sizeof(uint16_t), xs, ys, 1, 1, 0.0));
}

template <typename In>
void read_part(In& in, const std::vector<std::string>& names, RawPixels& out,
               const std::function<void(double)>& progress) {
    const Imath::Box2i dw = in.header().dataWindow();
    if (!in.isComplete()) throw std::runtime_error("file is truncated or damaged (rows are missing)");
    for (const std::string& n : names) {
        const Imf::Channel& c = in.header().channels()[n.c_str()];
        if (c.xSampling != 1 || c.ySampling != 1)
            throw std::runtime_error("channel '" + shown_name(n) +
                                     "' is subsampled, which iblbake does not read: write the file with every "
                                     "channel at full resolution");
    }
    out.channels = int(names.size());
    // Not zeroed first: every value is written by readPixels (each channel
    // asked for exists, the file is complete), by OpenEXR's threads, which
    // then also take the page faults of a large image in parallel.
    out.data.resize(size_t(out.width) * out.height * out.channels);
    Imf::FrameBuffer fb;
    if (three_half_channels(in.header().channels(), names)) {
        const size_t values = out.data.size();
        char* halves = reinterpret_cast<char*>(out.data.data()) + values * sizeof(uint16_t);
        insert_half_slices(fb, names, halves, dw.min.x, dw.min.y, out.width);
        in.setFrameBuffer(fb);
        read_in_bands(dw.min.y, dw.max.y, in.header().compression(), progress,
                      [&](int a, int b) { in.readPixels(a, b); });
        halves_to_floats(halves, out.data.data(), values);
        return;
    }
    const size_t xs = sizeof(float) * out.channels, ys = xs * out.width;
    char* base = reinterpret_cast<char*>(out.data.data()) - dw.min.x * ptrdiff_t(xs) - dw.min.y * ptrdiff_t(ys);
    for (int c = 0; c < out.channels; ++c)
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys, 1, 1, 0.0));
    in.setFrameBuffer(fb);
    read_in_bands(dw.min.y, dw.max.y, in.header().compression(), progress, [&](int a, int b) { in.readPixels(a, b); });
}

// Sizes and windows of the part that is read.
void take_windows(const Imf::Header& h, const Imf::ChannelList& ch, uintmax_t file_size, RawPixels& out) {
    const Imath::Box2i dw = h.dataWindow(), disp = h.displayWindow();
    const int64_t width = int64_t(dw.max.x) - dw.min.x + 1, height = int64_t(dw.max.y) - dw.min.y + 1;
    int declared_channels = 0;
    for (auto it = ch.begin(); it != ch.end(); ++it) ++declared_channels;
    check_declared(width, height, std::min(declared_channels, 3), file_size);
    out.width = int(width);
    out.height = int(height);
    out.full_width = checked_int(int64_t(disp.max.x) - disp.min.x + 1, "display window");
    out.full_height = checked_int(int64_t(disp.max.y) - disp.min.y + 1, "display window");
    out.x_offset = checked_int(int64_t(dw.min.x) - disp.min.x, "data window offset");
    out.y_offset = checked_int(int64_t(dw.min.y) - disp.min.y, "data window offset");
    if (out.full_width < 1 || out.full_height < 1) out.full_width = out.full_height = 0;
}

void note_choice(const ChannelChoice& c, RawPixels& out) {
    if (c.names == std::vector<std::string>{"Y"})
        out.warnings.push_back("the file has no colour channels, only luminance (Y): baked as grey");
    else if (!c.layer.empty())
        out.warnings.push_back("the file has no plain R, G, B channels: its layer '" + shown_name(c.layer) +
                               "' is baked as the colour");
}

// A multi-part file's part to bake: the first with colour (else the first
// with Y), and its channels; throws when no part holds an image.
int choose_part(Imf::MultiPartInputFile& file, ChannelChoice& choice) {
    int best = -1;
    std::string why;
    for (int i = 0; i < file.parts(); ++i) {
        const Imf::Header& h = file.header(i);
        if (h.hasType() && (h.type() == Imf::DEEPSCANLINE || h.type() == Imf::DEEPTILE)) continue;
        std::string part_why;
        ChannelChoice c = choose_channels(h.channels(), part_why);
        if (c.names.size() == 3) {
            best = i, choice = std::move(c);
            break;
        }
        if (!c.names.empty() && best < 0) best = i, choice = std::move(c);
        if (why.empty()) why = part_why;
    }
    if (best < 0)
        throw std::runtime_error("none of its " + std::to_string(file.parts()) + " parts holds an image to bake: " +
                                 (why.empty() ? "all are deep" : "the first one: " + why));
    return best;
}

// A multi-part file: the first part with colour (else the first with Y).
RawPixels read_exr_parts(const std::string& path, uintmax_t file_size, const std::function<void(double)>& progress) {
    Imf::MultiPartInputFile file(path.c_str(), exr_line_buffer_threads());
    ChannelChoice choice;
    const int best = choose_part(file, choice);
    RawPixels out;
    out.format = "openexr";
    const Imf::Header& h = file.header(best);
    take_windows(h, h.channels(), file_size, out);
    Imf::InputPart part(file, best);
    read_part(part, choice.names, out, progress);
    note_choice(choice, out);
    if (best > 0)
        out.warnings.push_back("the file has " + std::to_string(file.parts()) + " parts: part " + std::to_string(best) +
                               (h.hasName() ? " ('" + shown_name(h.name()) + "')" : std::string()) +
                               " holds the colour and is baked");
    return out;
}

}  // namespace

RawPixels read_exr(const std::string& path, uintmax_t file_size, const std::function<void(double)>& progress) {
    limit_exr_sizes();
    check_exr_headers(path, file_size);
    {
        std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
        unsigned char head[8] = {0};
        if (f && std::fread(head, 1, 8, f.get()) == 8 && (head[5] & 0x10)) return read_exr_parts(path, file_size, progress);
        if (head[5] & 0x08) throw std::runtime_error("a deep OpenEXR file (samples per pixel, not an image) cannot be baked");
    }
    RawPixels out;
    out.format = "openexr";
    const std::unique_ptr<Imf::InputFile> file = open_exr(path);
    Imf::InputFile& in = *file;
    const Imf::Header& h = in.header();
    const Imf::ChannelList& ch = h.channels();
    take_windows(h, ch, file_size, out);
    if (!in.isComplete()) throw std::runtime_error("file is truncated or damaged (rows are missing)");
    // Luminance-chroma files need OpenEXR's RGBA conversion (half precision).
    if (ch.findChannel("RY") || ch.findChannel("BY")) {
        const Imath::Box2i dw = h.dataWindow();
        Imf::RgbaInputFile rgba(path.c_str(), exr_line_buffer_threads());
        std::vector<Imf::Rgba> px(size_t(out.width) * out.height);
        rgba.setFrameBuffer(px.data() - dw.min.x - size_t(dw.min.y) * out.width, 1, out.width);
        read_in_bands(dw.min.y, dw.max.y, h.compression(), progress, [&](int a, int b) { rgba.readPixels(a, b); });
        out.channels = 3;
        out.data.resize(px.size() * 3);
        for (size_t p = 0; p < px.size(); ++p) {
            out.data[p * 3] = px[p].r;
            out.data[p * 3 + 1] = px[p].g;
            out.data[p * 3 + 2] = px[p].b;
        }
        return out;
    }
    std::string why;
    const ChannelChoice choice = choose_channels(ch, why);
    if (choice.names.empty()) throw std::runtime_error(why);
    read_part(in, choice.names, out, progress);
    note_choice(choice, out);
    return out;
}

void write_exr_file_rows(const std::string& path, int width, int height, int channels, bool half,
                         const std::function<void(int y0, int rows, float* out)>& fill) {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    header.zipCompressionLevel() = 1;  // 3 % larger files than level 4, written 20 % faster
    static const char* kNames[4] = {"R", "G", "B", "A"};
    const Imf::PixelType type = half ? Imf::HALF : Imf::FLOAT;
    for (int c = 0; c < channels; ++c) header.channels().insert(kNames[c], Imf::Channel(type));
    Imf::OutputFile file(path.c_str(), header);
    // Bands of 64 rows (four of ZIP's 16-line blocks): the file never needs
    // its whole image in memory, in float or in half.
    constexpr int kBand = 64;
    const int band = std::min(kBand, height);
    const size_t row = size_t(width) * channels;
    std::vector<float> values(row * band);
    std::vector<uint16_t> halves(half ? values.size() : 0);
    for (int y0 = 0; y0 < height; y0 += band) {
        const int rows = std::min(band, height - y0);
        fill(y0, rows, values.data());
        Imf::FrameBuffer fb;
        if (half) {
            floats_to_half(values.data(), halves.data(), row * rows);  // F16C where the CPU has it
            const size_t xs = sizeof(uint16_t) * channels, ys = xs * width;
            char* base = reinterpret_cast<char*>(halves.data()) - ptrdiff_t(y0) * ptrdiff_t(ys);
            for (int c = 0; c < channels; ++c)
                fb.insert(kNames[c], Imf::Slice(Imf::HALF, base + c * sizeof(::half), xs, ys));
        } else {
            const size_t xs = sizeof(float) * channels, ys = xs * width;
            char* base = reinterpret_cast<char*>(values.data()) - ptrdiff_t(y0) * ptrdiff_t(ys);
            for (int c = 0; c < channels; ++c)
                fb.insert(kNames[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
        }
        file.setFrameBuffer(fb);
        file.writePixels(rows);
    }
}

}  // namespace iblbake::io::detail

// ---------------------------------------------------------------------------
// ExrRowReader (io/row_reader.h): read_exr() and read_image()'s finish(), a
// band of rows at a time. Every choice (part, channels, windows, warnings) is
// made as read_exr and finish make it, by the same helpers where they are
// this file's; finish()'s window rule and its 2-channel warning are repeated
// here (image_io.cpp), and the test (tests/native/test_row_reader.cpp) holds
// the two to the same values.

namespace iblbake::io {

struct ExrRowReader::Impl {
    std::string path;
    std::unique_ptr<Imf::InputFile> file;
    std::unique_ptr<Imf::MultiPartInputFile> multi;
    std::unique_ptr<Imf::InputPart> part;
    std::unique_ptr<Imf::RgbaInputFile> rgba;  // luminance-chroma files (RY, BY)
    Imath::Box2i dw;
    Imf::Compression compression = Imf::ZIP_COMPRESSION;
    int tile_rows = 0;                 // a tiled file's tile height, else 0
    std::vector<std::string> names;    // the channels read (1 to 3)
    int data_w = 0, data_h = 0;        // the data window
    int w = 0, h = 0, ox = 0, oy = 0;  // the rows handed out, and the data's place in them
    std::vector<std::string> warnings;
    std::vector<float> tmp;
    std::vector<Imf::Rgba> tmp_rgba;
    bool all_half = false;           // detail::three_half_channels
    // Scanline ZIP and ZIPS blocks of three HALF channels are decoded here
    // (exr_zip.h): OpenEXR reads each block's bytes, libdeflate inflates
    // them (in the Python module too, where OpenEXR's own calls go to zlib),
    // and the predictor, the byte split and the channels' interleaving are
    // undone in one place, by the pool's threads.
    bool zip_direct = false;
    detail::HalfPlanes planes;
    int block_lines = 0;
    struct Scratch {
        std::vector<uint8_t> packed, inflated;  // a block as read, and inflated
    };
    std::vector<Scratch> scratch;  // each task's

    int channels() const { return rgba ? 3 : int(names.size()); }

    void check_part(const Imf::Header& h, bool complete) {
        if (!complete) throw std::runtime_error("file is truncated or damaged (rows are missing)");
        for (const std::string& n : names) {
            const Imf::Channel& c = h.channels()[n.c_str()];
            if (c.xSampling != 1 || c.ySampling != 1)
                throw std::runtime_error("channel '" + detail::shown_name(n) +
                                         "' is subsampled, which iblbake does not read: write the file with every "
                                         "channel at full resolution");
        }
    }

    void take(const Imf::Header& h, uintmax_t file_size) {
        detail::RawPixels r;
        detail::take_windows(h, h.channels(), file_size, r);
        dw = h.dataWindow();
        compression = h.compression();
        tile_rows = h.hasTileDescription() ? int(h.tileDescription().ySize) : 0;
        data_w = r.width;
        data_h = r.height;
        w = r.full_width > 0 ? r.full_width : data_w;
        apply_window(r);
    }

    // finish()'s window rule (image_io.cpp).
    void apply_window(const detail::RawPixels& r) {
        const int dwid = r.width, dhei = r.height;
        h = r.full_height > 0 ? r.full_height : dhei;
        ox = r.x_offset;
        oy = r.y_offset;
        if (w != dwid || h != dhei || ox != 0 || oy != 0) {
            auto size_text = [](int64_t a, int64_t b) { return std::to_string(a) + " x " + std::to_string(b); };
            const bool inside = ox >= 0 && oy >= 0 && int64_t(ox) + dwid <= w && int64_t(oy) + dhei <= h;
            const bool modest = int64_t(w) * h <= 4 * int64_t(dwid) * dhei;
            if (inside && modest) {
                check_source_size(w, h, "display window");
                window_warning = "the data window (" + size_text(dwid, dhei) + ") covers part of the display window (" +
                                 size_text(w, h) + "): the rest is baked as black";
            } else {
                window_warning = std::string("the data window (") + size_text(dwid, dhei) + " at " +
                                 std::to_string(ox) + ", " + std::to_string(oy) + ") " +
                                 (inside ? "is far smaller than" : "lies outside") + " the display window (" +
                                 size_text(w, h) + "): the data window alone is baked";
                w = dwid, h = dhei, ox = oy = 0;
            }
        }
    }
    std::string window_warning;

    void open(const std::string& path) {
        detail::limit_exr_sizes();
        std::error_code ec;
        if (!std::filesystem::is_regular_file(path, ec)) throw std::runtime_error("not a regular file");
        const uintmax_t file_size = std::filesystem::file_size(path, ec);
        if (ec) throw std::runtime_error(ec.message());
        if (file_size == 0) throw std::runtime_error("file is empty");
        if (!Imf::isOpenExrFile(path.c_str())) throw std::runtime_error("not an OpenEXR file");
        detail::check_exr_headers(path, file_size);
        unsigned char head[8] = {0};
        {
            std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
            if (!f || std::fread(head, 1, 8, f.get()) != 8) throw std::runtime_error("file is truncated (no header)");
        }
        std::vector<std::string> reader_warnings;
        if (head[5] & 0x10) {  // read_exr_parts' choice
            multi = std::make_unique<Imf::MultiPartInputFile>(path.c_str(), detail::exr_line_buffer_threads());
            detail::ChannelChoice choice;
            const int best = detail::choose_part(*multi, choice);
            const Imf::Header& hd = multi->header(best);
            take(hd, file_size);
            part = std::make_unique<Imf::InputPart>(*multi, best);
            names = choice.names;
            check_part(hd, part->isComplete());
            detail::RawPixels notes;
            detail::note_choice(choice, notes);
            reader_warnings = notes.warnings;
            if (best > 0)
                reader_warnings.push_back("the file has " + std::to_string(multi->parts()) + " parts: part " +
                                          std::to_string(best) +
                                          (hd.hasName() ? " ('" + detail::shown_name(hd.name()) + "')" : std::string()) +
                                          " holds the colour and is baked");
        } else {
            if (head[5] & 0x08)
                throw std::runtime_error("a deep OpenEXR file (samples per pixel, not an image) cannot be baked");
            file = detail::open_exr(path);
            const Imf::Header& hd = file->header();
            take(hd, file_size);
            if (!file->isComplete()) throw std::runtime_error("file is truncated or damaged (rows are missing)");
            if (hd.channels().findChannel("RY") || hd.channels().findChannel("BY")) {
                file.reset();
                rgba = std::make_unique<Imf::RgbaInputFile>(path.c_str(), detail::exr_line_buffer_threads());
            } else {
                std::string why;
                const detail::ChannelChoice choice = detail::choose_channels(hd.channels(), why);
                if (choice.names.empty()) throw std::runtime_error(why);
                names = choice.names;
                check_part(hd, true);
                detail::RawPixels notes;
                detail::note_choice(choice, notes);
                reader_warnings = notes.warnings;
            }
        }
        if (!rgba) {
            all_half = detail::three_half_channels((part ? part->header() : file->header()).channels(), names);
            plan_zip(part ? part->header() : file->header());
        }
        // finish()'s order: the reader's warnings, the window's, the channels'.
        warnings = reader_warnings;
        if (!window_warning.empty()) warnings.push_back(window_warning);
        if (channels() == 2)
            warnings.push_back("the file has 2 colour channels, neither grey nor RGB: baked as grey from the first");
    }

    // Whether the blocks can be decoded here: has_halves(), scanlines, ZIP
    // or ZIPS, every channel of the file at full resolution (so a line's
    // layout is known), a little-endian host.
    void plan_zip(const Imf::Header& hd) {
#if __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
        if (!has_halves() || hd.hasTileDescription()) return;
        if (compression != Imf::ZIP_COMPRESSION && compression != Imf::ZIPS_COMPRESSION) return;
        detail::HalfPlanes found_at;
        int found = 0;
        for (Imf::ChannelList::ConstIterator it = hd.channels().begin(); it != hd.channels().end(); ++it) {
            const Imf::Channel& c = it.channel();
            if (c.xSampling != 1 || c.ySampling != 1) return;
            for (int k = 0; k < 3; ++k)
                if (names[size_t(k)] == it.name()) found_at.plane[k] = found_at.line_bytes, ++found;
            found_at.line_bytes += size_t(c.type == Imf::HALF ? 2 : 4) * size_t(data_w);
        }
        if (found != 3) return;
        planes = found_at;
        block_lines = detail::lines_per_block(compression);
        zip_direct = true;
#else
        (void)hd;
#endif
    }

    // File rows fa .. fb as RGB halves into out, by a task per thread of
    // OpenEXR's pool, each taking the next block in turn: its bytes read
    // (OpenEXR's rawPixelDataToBuffer, which checks the block's place and
    // size; one read at a time), inflated and undone, while the other tasks
    // decode theirs. A block that does not inflate to its size is an error.
    // (Reading a band's blocks first, then splitting them between the tasks,
    // left the pool idle during the reads and whichever task finished
    // first idle at the end: a 16K bake's two cores were 1.75 busy on
    // average during its pass, now 1.9 to 2.0; the bake was 4 % faster.)
    void read_zip_halves(int fa, int fb, uint16_t* out) {
        const int b0 = (fa - dw.min.y) / block_lines, b1 = (fb - dw.min.y) / block_lines, nb = b1 - b0 + 1;
        // A block is at most its rows' size (OpenEXR refuses a longer one).
        const size_t full = size_t(block_lines) * planes.line_bytes;
        const int tasks = std::min(nb, detail::exr_threads());
        if (scratch.size() < size_t(tasks)) scratch.resize(size_t(tasks));
        std::atomic<int> next{0};
        std::mutex read_mx, failed_mx;
        std::exception_ptr failed;  // the first task's error, rethrown as it was (out of memory stays that)
        auto run = [&](int t) {
            try {
                Scratch& mine = scratch[size_t(t)];
                if (mine.packed.size() < full) mine.packed.resize(full);
                libdeflate_decompressor* const inflater = thread_decompressor();  // this thread's, kept for its life
                if (!inflater) throw std::bad_alloc();
                for (int k; (k = next.fetch_add(1, std::memory_order_relaxed)) < nb;) {
                    {
                        const std::lock_guard<std::mutex> lock(failed_mx);
                        if (failed) return;
                    }
                    const int y = dw.min.y + (b0 + k) * block_lines;
                    int size = int(full);
                    {
                        const std::lock_guard<std::mutex> lock(read_mx);
                        char* to = reinterpret_cast<char*>(mine.packed.data());
                        if (part)
                            part->rawPixelDataToBuffer(y, to, size);
                        else
                            file->rawPixelDataToBuffer(y, to, size);
                    }
                    const int lines = std::min(block_lines, dw.max.y - y + 1);
                    const int first = std::max(fa, y) - y, last = std::min(fb, y + lines - 1) - y;
                    const size_t bytes = size_t(lines) * planes.line_bytes;
                    uint16_t* o = out + size_t(y + first - fa) * size_t(data_w) * 3;
                    const uint8_t* data = mine.packed.data();
                    if (size_t(size) == bytes) {
                        detail::plain_block_to_rgb(data, planes, data_w, first, last - first + 1, o);
                        continue;
                    }
                    if (mine.inflated.size() < bytes) mine.inflated.resize(bytes);
                    size_t got = 0;
                    if (size_t(size) > bytes ||
                        libdeflate_zlib_decompress(inflater, data, size_t(size), mine.inflated.data(), bytes, &got) !=
                            LIBDEFLATE_SUCCESS ||
                        got != bytes)
                        throw std::runtime_error("the block of rows from " + std::to_string(y) +
                                                 " does not decompress (damaged zlib data)");
                    detail::undo_zip_predictor(mine.inflated.data(), bytes);
                    detail::split_block_to_rgb(mine.inflated.data(), bytes, planes, data_w, first, last - first + 1, o);
                }
            } catch (...) {
                const std::lock_guard<std::mutex> lock(failed_mx);
                if (!failed) failed = std::current_exception();
            }
        };
        struct Block final : ILMTHREAD_NAMESPACE::Task {
            Block(ILMTHREAD_NAMESPACE::TaskGroup* g, decltype(run)& f, int t) : Task(g), f_(f), t_(t) {}
            void execute() override { f_(t_); }
            decltype(run)& f_;
            int t_;
        };
        {
            ILMTHREAD_NAMESPACE::TaskGroup group;  // waits for its tasks when it goes
            for (int t = 0; t < tasks; ++t) ILMTHREAD_NAMESPACE::ThreadPool::addGlobalTask(new Block(&group, run, t));
        }
        if (failed) std::rethrow_exception(failed);
    }

    void read_file_rows(int fa, int fb, Imf::FrameBuffer& fb_) {
        if (part) {
            part->setFrameBuffer(fb_);
            part->readPixels(fa, fb);
        } else {
            file->setFrameBuffer(fb_);
            file->readPixels(fa, fb);
        }
    }

    bool has_halves() const {
        return !rgba && all_half && names.size() == 3 && ox == 0 && oy == 0 && w == data_w && h == data_h;
    }

    void read_halves(int y0, int rows, uint16_t* out) {
        if (!has_halves()) throw std::logic_error("ExrRowReader::read_halves: the rows are not halves");
        if (rows <= 0) return;
        if (y0 < 0 || rows > h || y0 > h - rows) throw std::out_of_range("rows outside the image");
        const int fa = y0 + dw.min.y;
        if (zip_direct) {
            read_zip_halves(fa, fa + rows - 1, out);
            return;
        }
        Imf::FrameBuffer fbuf;
        detail::insert_half_slices(fbuf, names, reinterpret_cast<char*>(out), dw.min.x, fa, data_w);
        read_file_rows(fa, fa + rows - 1, fbuf);
    }

    void read(int y0, int rows, float* out) {
        if (rows <= 0) return;
        if (y0 < 0 || rows > h || y0 > h - rows) throw std::out_of_range("rows outside the image");
        const size_t row_values = size_t(w) * 3;
        // Output rows a .. b hold data rows (file rows fa .. fb); the rest are black.
        const int a = std::max(y0, oy), b = std::min(y0 + rows, oy + data_h) - 1;
        for (int y = y0; y < y0 + rows; ++y)
            if (y < a || y > b) std::fill_n(out + size_t(y - y0) * row_values, row_values, 0.0f);
        if (a > b) return;
        const int fa = a - oy + dw.min.y, fb = b - oy + dw.min.y, n = b - a + 1;
        float* first = out + size_t(a - y0) * row_values;
        if (rgba) {
            tmp_rgba.resize(size_t(n) * data_w);
            rgba->setFrameBuffer(tmp_rgba.data() - dw.min.x - ptrdiff_t(fa) * data_w, 1, size_t(data_w));
            rgba->readPixels(fa, fb);
            for (int r = 0; r < n; ++r) {
                float* o = first + size_t(r) * row_values;
                std::fill_n(o, size_t(ox) * 3, 0.0f);
                std::fill_n(o + size_t(ox + data_w) * 3, size_t(w - ox - data_w) * 3, 0.0f);
                const Imf::Rgba* px = tmp_rgba.data() + size_t(r) * data_w;
                for (int x = 0; x < data_w; ++x) {
                    o[size_t(ox + x) * 3] = px[x].r;
                    o[size_t(ox + x) * 3 + 1] = px[x].g;
                    o[size_t(ox + x) * 3 + 2] = px[x].b;
                }
            }
            return;
        }
        const int nch = int(names.size());
        Imf::FrameBuffer fbuf;
        const size_t xs = sizeof(float) * nch, ys = xs * data_w;
        if (nch == 3 && ox == 0 && w == data_w && all_half) {
            // Into the upper half of the caller's rows, which the floats
            // then fill from the start: no buffer of their own.
            const size_t values = size_t(n) * data_w * 3;
            char* halves = reinterpret_cast<char*>(first) + values * sizeof(uint16_t);
            if (zip_direct) {
                read_zip_halves(fa, fb, reinterpret_cast<uint16_t*>(halves));
            } else {
                detail::insert_half_slices(fbuf, names, halves, dw.min.x, fa, data_w);
                read_file_rows(fa, fb, fbuf);
            }
            halves_to_floats(halves, first, values);
            return;
        }
        if (nch == 3 && ox == 0 && w == data_w) {  // straight into the caller's rows
            char* base = reinterpret_cast<char*>(first) - dw.min.x * ptrdiff_t(xs) - fa * ptrdiff_t(ys);
            for (int c = 0; c < 3; ++c) fbuf.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys, 1, 1, 0.0));
            read_file_rows(fa, fb, fbuf);
            return;
        }
        tmp.resize(size_t(n) * data_w * nch);
        char* base = reinterpret_cast<char*>(tmp.data()) - dw.min.x * ptrdiff_t(xs) - fa * ptrdiff_t(ys);
        for (int c = 0; c < nch; ++c) fbuf.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys, 1, 1, 0.0));
        read_file_rows(fa, fb, fbuf);
        // finish(): three channels as they are, fewer as grey from the first.
        for (int r = 0; r < n; ++r) {
            float* o = first + size_t(r) * row_values;
            std::fill_n(o, size_t(ox) * 3, 0.0f);
            std::fill_n(o + size_t(ox + data_w) * 3, size_t(w - ox - data_w) * 3, 0.0f);
            const float* px = tmp.data() + size_t(r) * data_w * nch;
            for (int x = 0; x < data_w; ++x)
                for (int k = 0; k < 3; ++k) o[size_t(ox + x) * 3 + k] = px[size_t(x) * nch + (nch == 3 ? k : 0)];
        }
    }
};

ExrRowReader::ExrRowReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
    impl_->path = path;
    try {
        impl_->open(path);
    } catch (const std::bad_alloc&) {
        detail::fail_reading(path, "out of memory while reading");
    } catch (const std::exception& e) {
        detail::fail_reading(path, e.what());
    }
}

ExrRowReader::~ExrRowReader() = default;
int ExrRowReader::width() const { return impl_->w; }
int ExrRowReader::height() const { return impl_->h; }
const std::vector<std::string>& ExrRowReader::warnings() const { return impl_->warnings; }

bool ExrRowReader::has_halves() const { return impl_->has_halves(); }

void ExrRowReader::read_halves(int y0, int rows, uint16_t* out) {
    try {
        impl_->read_halves(y0, rows, out);
    } catch (const std::logic_error&) {
        throw;  // the caller's rows or call, not the file
    } catch (const std::bad_alloc&) {
        detail::fail_reading(impl_->path, "out of memory while reading");
    } catch (const std::exception& e) {
        detail::fail_reading(impl_->path, e.what());
    }
}

int ExrRowReader::preferred_band() const {
    const int block = impl_->tile_rows > 0 ? impl_->tile_rows : detail::lines_per_block(impl_->compression);
    const int threads = detail::exr_threads();
    const int band = std::max(128, block * threads);
    return (band + block - 1) / block * block;
}

void ExrRowReader::read(int y0, int rows, float* out) {
    try {
        impl_->read(y0, rows, out);
    } catch (const std::out_of_range&) {
        throw;  // the caller's rows, not the file
    } catch (const std::bad_alloc&) {
        detail::fail_reading(impl_->path, "out of memory while reading");
    } catch (const std::exception& e) {  // a block that does not decode (OpenEXR's Iex exceptions)
        detail::fail_reading(impl_->path, e.what());
    }
}

}  // namespace iblbake::io
