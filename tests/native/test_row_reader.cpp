// io::ExrRowReader and io::open_rows (issue 28's streaming bake,
// docs/design-streaming.md): the rows they hand out, in bands of any height
// and in any order, are read_image()'s image value for value, with its size
// and warnings; what streams and what is read whole.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfMultiPartOutputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfOutputPart.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <OpenEXR/ImfTileDescription.h>
#include <OpenEXR/ImfTiledOutputFile.h>
#include <OpenEXR/ImfTiledOutputPart.h>
#include <Imath/half.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "iblbake/io/image_io.h"
#include "iblbake/io/row_reader.h"
#include "iblbake/ibl/bin_tree.h"
#include "iblbake/ibl/source.h"
#include "iblbake/ibl/specular.h"
#include "iblbake/math/half.h"
#include "exr_zip.h"
#include "reference.h"
#include "scratch.h"
#include "test_files.h"

namespace fs = std::filesystem;
using namespace iblbake;

namespace {

fs::path temp_file(const std::string& name) {
    const fs::path dir = scratch::root() / "rows";
    fs::create_directories(dir);
    return dir / name;
}

// Values that differ per channel, row and column, some far from 1 (and exact in half).
float value(int x, int y, int c) { return float((x * 7 + y * 13 + c * 5) % 61) * 0.25f + (c == 1 ? 1000.0f : 0.0f); }

struct Layout {
    int w = 37, h = 19;                                     // data window size
    int dx = 0, dy = 0;                                     // data window origin
    int full_w = 0, full_h = 0;                             // display window (0: the data window)
    std::vector<std::string> channels{"R", "G", "B"};
    bool half = true, tiled = false;
    Imf::Compression compression = Imf::ZIP_COMPRESSION;
};

Imf::Header header_of(const Layout& l) {
    const Imath::Box2i data(Imath::V2i(l.dx, l.dy), Imath::V2i(l.dx + l.w - 1, l.dy + l.h - 1));
    const Imath::Box2i display =
        l.full_w > 0 ? Imath::Box2i(Imath::V2i(0, 0), Imath::V2i(l.full_w - 1, l.full_h - 1)) : data;
    Imf::Header hd(display, data);
    hd.compression() = l.compression;
    for (const std::string& n : l.channels) hd.channels().insert(n, Imf::Channel(l.half ? Imf::HALF : Imf::FLOAT));
    if (l.tiled) hd.setTileDescription(Imf::TileDescription(16, 8));
    return hd;
}

// The pixels of a layout, one buffer per channel (half or float), and a frame buffer over them.
struct Pixels {
    std::vector<std::vector<half>> halves;
    std::vector<std::vector<float>> floats;
    Imf::FrameBuffer fb;
    explicit Pixels(const Layout& l) {
        for (size_t c = 0; c < l.channels.size(); ++c) {
            const size_t n = size_t(l.w) * l.h;
            if (l.half) {
                halves.emplace_back(n);
                for (int y = 0; y < l.h; ++y)
                    for (int x = 0; x < l.w; ++x) halves.back()[size_t(y) * l.w + x] = half(value(x, y, int(c)));
                char* base = reinterpret_cast<char*>(halves.back().data() - l.dx - ptrdiff_t(l.dy) * l.w);
                fb.insert(l.channels[c], Imf::Slice(Imf::HALF, base, sizeof(half), sizeof(half) * l.w));
            } else {
                floats.emplace_back(n);
                for (int y = 0; y < l.h; ++y)
                    for (int x = 0; x < l.w; ++x) floats.back()[size_t(y) * l.w + x] = value(x, y, int(c));
                char* base = reinterpret_cast<char*>(floats.back().data() - l.dx - ptrdiff_t(l.dy) * l.w);
                fb.insert(l.channels[c], Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * l.w));
            }
        }
    }
};

std::string write_file(const std::string& name, const Layout& l) {
    const std::string path = temp_file(name).string();
    Imf::Header hd = header_of(l);
    Pixels px(l);
    if (l.tiled) {
        Imf::TiledOutputFile out(path.c_str(), hd);
        out.setFrameBuffer(px.fb);
        out.writeTiles(0, out.numXTiles() - 1, 0, out.numYTiles() - 1);
    } else {
        Imf::OutputFile out(path.c_str(), hd);
        out.setFrameBuffer(px.fb);
        out.writePixels(l.h);
    }
    return path;
}

// Every row, read in bands of `band` rows (last band first when `backwards`).
std::vector<float> read_in_bands(io::RowReader& r, int band, bool backwards) {
    std::vector<float> all(size_t(r.width()) * r.height() * 3, -1.0f);
    std::vector<int> starts;
    for (int y = 0; y < r.height(); y += band) starts.push_back(y);
    if (backwards) std::reverse(starts.begin(), starts.end());
    for (int y : starts) {
        const int rows = std::min(band, r.height() - y);
        r.read(y, rows, all.data() + size_t(y) * r.width() * 3);
    }
    return all;
}

// Every row as halves (read_halves), in bands of `band` rows, made floats.
std::vector<float> halves_in_bands(io::RowReader& r, int band) {
    const size_t row = size_t(r.width()) * 3;
    std::vector<uint16_t> h(row * r.height(), 0xffff);
    for (int y = 0; y < r.height(); y += band) r.read_halves(y, std::min(band, r.height() - y), h.data() + y * row);
    std::vector<float> all(h.size());
    halves_to_floats(h.data(), all.data(), h.size());
    return all;
}

// `halves`: whether the reader must offer its rows as halves (a file of
// three HALF channels whose data window is the image), which then equal
// the floats too.
void expect_same_as_read_image(const std::string& path, std::vector<int> bands = {1, 7, 64, 1000},
                               std::optional<bool> halves = std::nullopt) {
    const io::LoadedImage whole = io::read_image(path);
    const std::unique_ptr<io::RowReader> reader = io::open_rows(path);  // an ExrRowReader for an EXR
    ASSERT_TRUE(reader) << path << " is read whole, not by rows";
    io::RowReader& r = *reader;
    if (halves) {
        ASSERT_EQ(r.has_halves(), *halves) << path;
    }
    if (r.has_halves())
        for (int band : {1, 7, r.preferred_band()}) {
            const std::vector<float> rows = halves_in_bands(r, band);
            EXPECT_EQ(0, std::memcmp(rows.data(), whole.image.pixels.data(), rows.size() * sizeof(float)))
                << path << ": halves in bands of " << band;
        }
    else
        EXPECT_THROW(r.read_halves(0, 1, nullptr), std::logic_error) << path;
    ASSERT_EQ(r.width(), whole.image.width);
    ASSERT_EQ(r.height(), whole.image.height);
    EXPECT_EQ(r.warnings(), whole.warnings);
    EXPECT_GE(r.preferred_band(), 1);
    bands.push_back(r.preferred_band());
    for (int band : bands)
        for (bool backwards : {false, true}) {
            const std::vector<float> rows = read_in_bands(r, band, backwards);
            ASSERT_EQ(rows.size(), whole.image.pixels.size());
            EXPECT_EQ(0, std::memcmp(rows.data(), whole.image.pixels.data(), rows.size() * sizeof(float)))
                << path << ": bands of " << band << (backwards ? ", last first" : "");
        }
}

}  // namespace

TEST(ExrRowReader, ScanlineZipHalf) {
    expect_same_as_read_image(write_file("scanline.exr", Layout{}), {1, 7, 64, 1000}, true);
    Layout moved;
    moved.dx = 3, moved.dy = -5;  // the data window is the display window, away from the origin
    expect_same_as_read_image(write_file("moved.exr", moved), {1, 7, 64, 1000}, true);
}

// The predictor undone 16 bytes at a time is the byte loop's answer, at
// every length around the vectors' edges.
TEST(ExrZip, PredictorIsTheDefinition) {
    std::mt19937 rng(7);
    for (size_t n : {0, 1, 2, 15, 16, 17, 18, 31, 32, 33, 34, 47, 48, 49, 63, 64, 65, 1000, 4099}) {
        std::vector<uint8_t> a(n);
        for (uint8_t& b : a) b = uint8_t(rng());
        std::vector<uint8_t> b = a;
#if defined(__x86_64__)
        std::vector<uint8_t> c = a;
        io::detail::undo_zip_predictor_sse2(c.data(), n);
#endif
        io::detail::undo_zip_predictor(a.data(), n);  // AVX2 where the CPU has it
        io::detail::undo_zip_predictor_scalar(b.data(), n);
        EXPECT_EQ(a, b) << n << " bytes";
#if defined(__x86_64__)
        EXPECT_EQ(c, b) << n << " bytes, SSE2";
#endif
    }
}

// A block's R, G, B halves interleaved 16 pixels at a time are the
// definition's, for widths around the vectors' edges, planes in any order,
// a float channel among them, and lines from inside the block.
TEST(ExrZip, SplitBlockIsTheDefinition) {
    std::mt19937 rng(11);
    for (int width : {1, 15, 16, 17, 31, 32, 33, 100}) {
        io::detail::HalfPlanes p;
        // A (half), B, G, R (half), Z (float): R, G, B at planes 3, 2, 1.
        p.line_bytes = size_t(width) * (2 * 4 + 4);
        p.plane[0] = size_t(width) * 6, p.plane[1] = size_t(width) * 4, p.plane[2] = size_t(width) * 2;
        const int lines = 5;
        for (size_t extra : {0, 1}) {  // an odd size: the high bytes start one later
            const size_t size = p.line_bytes * lines + extra;
            std::vector<uint8_t> block(size);
            for (uint8_t& b : block) b = uint8_t(rng());
            std::vector<uint16_t> a(size_t(width) * 3 * 3, 1), b(a.size(), 2);
            io::detail::split_block_to_rgb(block.data(), size, p, width, 1, 3, a.data());
            io::detail::split_block_to_rgb_scalar(block.data(), size, p, width, 1, 3, b.data());
            EXPECT_EQ(a, b) << width << " wide";
            // The definition itself, for one value: line 2's G at the last column.
            const size_t at = (2 * p.line_bytes + p.plane[1]) / 2 + size_t(width - 1);
            EXPECT_EQ(b[(size_t(width) * 2 - 1) * 3 + 1], uint16_t(block[at] | (block[(size + 1) / 2 + at] << 8)));
        }
    }
}

namespace {

// A scanline file of `channels` (name, type) pairs, ZIP or ZIPS, w x h at
// (-3, 5): every channel's values from value(), or noise that zlib cannot
// shrink (so the blocks are stored as they are) when `noise`.
std::string write_mixed(const std::string& name, int w, int h, Imf::Compression comp,
                        const std::vector<std::pair<std::string, Imf::PixelType>>& channels, bool noise) {
    const std::string path = temp_file(name).string();
    const Imath::Box2i dw(Imath::V2i(-3, 5), Imath::V2i(-3 + w - 1, 5 + h - 1));
    Imf::Header hd(dw, dw);
    hd.compression() = comp;
    for (const auto& [n, t] : channels) hd.channels().insert(n, Imf::Channel(t));
    std::vector<std::vector<uint32_t>> store;
    std::mt19937 rng(unsigned(w * 1000 + h));
    Imf::FrameBuffer fb;
    int c = 0;
    for (const auto& [n, t] : channels) {
        store.emplace_back(size_t(w) * h);
        std::vector<uint32_t>& v = store.back();
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const float f = value(x, y, c);
                uint32_t bits = 0;
                if (t == Imf::HALF)
                    bits = noise ? (rng() & 0xffffu) : half(f).bits();
                else
                    std::memcpy(&bits, &f, 4);
                v[size_t(y) * w + x] = bits;
            }
        char* base = reinterpret_cast<char*>(v.data()) - (dw.min.x + ptrdiff_t(dw.min.y) * w) * 4;
        fb.insert(n, Imf::Slice(t, base, 4, size_t(w) * 4));
        ++c;
    }
    Imf::OutputFile out(path.c_str(), hd);
    out.setFrameBuffer(fb);
    out.writePixels(h);
    return path;
}

}  // namespace

// ZIP and ZIPS files of three HALF channels (decoded by ExrRowReader itself,
// exr_zip.h) give read_image's rows (OpenEXR's own decoding), halves and
// floats, in bands that start and end inside blocks: other channels around
// R, G, B (a float among them), a layer, widths and heights around the
// vectors' and blocks' edges, blocks stored uncompressed.
TEST(ExrRowReader, ZipBlocksOfEveryLayout) {
    using C = std::vector<std::pair<std::string, Imf::PixelType>>;
    const C rgb{{"R", Imf::HALF}, {"G", Imf::HALF}, {"B", Imf::HALF}};
    const C around{{"A", Imf::HALF}, {"R", Imf::HALF}, {"G", Imf::HALF}, {"B", Imf::HALF}, {"Z", Imf::FLOAT}};
    const C layer{{"diffuse.R", Imf::HALF}, {"diffuse.G", Imf::HALF}, {"diffuse.B", Imf::HALF},
                  {"depth.Z", Imf::FLOAT}, {"N.X", Imf::HALF}};
    int k = 0;
    for (Imf::Compression comp : {Imf::ZIP_COMPRESSION, Imf::ZIPS_COMPRESSION})
        for (const C* ch : {&rgb, &around, &layer})
            for (auto [w, h] : {std::pair{1, 1}, {17, 33}, {61, 16}, {300, 40}})
                for (bool noise : {false, true}) {
                    const std::string path = write_mixed("mixed" + std::to_string(k++) + ".exr", w, h, comp, *ch, noise);
                    if (noise && w == 300 && ch == &rgb) {  // the first block is stored as it is: zlib could not shrink it
                        Imf::InputFile in(path.c_str());
                        const char* data = nullptr;
                        int size = 0;
                        in.rawPixelData(5, data, size);
                        const int lines = comp == Imf::ZIP_COMPRESSION ? 16 : 1;
                        EXPECT_EQ(size, lines * w * 6) << path;
                    }
                    expect_same_as_read_image(path, {1, 5, 16, 24}, true);
                }
}

// A ZIP block whose zlib data is damaged (one byte in its middle changed) is
// an error naming the file, from the halves and the floats alike.
TEST(ExrRowReader, DamagedZipBlockIsAnError) {
    Layout l;
    l.w = 200, l.h = 40;
    const std::string good = write_file("undamaged.exr", l);
    std::string block;
    {
        Imf::InputFile in(good.c_str());
        const char* data = nullptr;
        int size = 0;
        in.rawPixelData(in.header().dataWindow().min.y + 16, data, size);  // the second block
        block.assign(data, size_t(size));
    }
    std::ifstream f(good, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    const size_t at = bytes.find(block);
    ASSERT_NE(at, std::string::npos);
    ASSERT_GT(block.size(), 100u);
    bytes[at + block.size() / 2] = char(bytes[at + block.size() / 2] ^ 0x5a);
    const std::string path = temp_file("damaged.exr").string();
    std::ofstream(path, std::ios::binary) << bytes;
    io::ExrRowReader r(path);
    ASSERT_TRUE(r.has_halves());
    std::vector<uint16_t> h(size_t(l.w) * l.h * 3);
    std::vector<float> v(h.size());
    EXPECT_NO_THROW(r.read_halves(0, 16, h.data()));  // the first block is whole
    for (int pass = 0; pass < 2; ++pass) {
        try {
            if (pass == 0)
                r.read_halves(0, l.h, h.data());
            else
                r.read(8, 16, v.data());
            ADD_FAILURE() << "a damaged block was read";
        } catch (const std::runtime_error& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find("cannot read"), std::string::npos) << what;
            EXPECT_NE(what.find("does not decompress"), std::string::npos) << what;
        }
    }
}

TEST(ExrRowReader, ScanlineFloatPiz) {
    Layout l;
    l.half = false;
    l.compression = Imf::PIZ_COMPRESSION;
    l.h = 70;  // more than a PIZ block of 32 rows
    expect_same_as_read_image(write_file("piz.exr", l), {1, 7, 64, 1000}, false);
}

TEST(ExrRowReader, Tiled) {
    Layout l;
    l.tiled = true;
    l.w = 50, l.h = 29;  // partial tiles at the right and bottom
    expect_same_as_read_image(write_file("tiled.exr", l), {1, 7, 64, 1000}, true);
}

TEST(ExrRowReader, DataWindowInsideTheDisplayWindow) {
    Layout l;
    l.dx = 3, l.dy = 5, l.full_w = 48, l.full_h = 24;  // padded with black, warned
    expect_same_as_read_image(write_file("window.exr", l), {1, 7, 64, 1000}, false);  // black rows and columns: floats
}

TEST(ExrRowReader, DataWindowOutsideTheDisplayWindow) {
    Layout l;
    l.dx = -4, l.dy = 2, l.full_w = 40, l.full_h = 20;  // the data window alone, warned
    l.tiled = true;
    expect_same_as_read_image(write_file("outside.exr", l), {1, 7, 64, 1000}, true);  // the data window is the image
}

TEST(ExrRowReader, GreyFromYAndFromTwoChannels) {
    Layout y;
    y.channels = {"Y"};
    expect_same_as_read_image(write_file("grey.exr", y), {1, 7, 64, 1000}, false);
    Layout two;
    two.channels = {"R", "G"};
    expect_same_as_read_image(write_file("two.exr", two), {1, 7, 64, 1000}, false);
}

TEST(ExrRowReader, LayerOfAMultilayerFile) {
    Layout l;
    l.channels = {"ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B", "ViewLayer.Depth.Z"};
    expect_same_as_read_image(write_file("layers.exr", l), {1, 7, 64, 1000}, true);
}

TEST(ExrRowReader, LuminanceChroma) {
    const std::string path = temp_file("yc.exr").string();
    const int w = 40, h = 22;
    std::vector<Imf::Rgba> px(size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) px[size_t(y) * w + x] = Imf::Rgba(value(x, y, 0), value(x, y, 1), value(x, y, 2));
    {
        Imf::RgbaOutputFile out(path.c_str(), w, h, Imf::WRITE_YC);
        out.setFrameBuffer(px.data(), 1, w);
        out.writePixels(h);
    }
    expect_same_as_read_image(path, {1, 7, 64, 1000}, false);  // RgbaInputFile's conversion
}

TEST(ExrRowReader, MultiPartTakesThePartWithColour) {
    const std::string path = temp_file("parts.exr").string();
    Layout depth;
    depth.channels = {"Z"};
    depth.half = false;
    Layout colour;
    colour.tiled = true;
    Imf::Header h0 = header_of(depth), h1 = header_of(colour);
    h0.setName("depth");
    h0.setType(Imf::SCANLINEIMAGE);
    h1.setName("beauty");
    h1.setType(Imf::TILEDIMAGE);
    const Imf::Header headers[2] = {h0, h1};
    {
        Imf::MultiPartOutputFile out(path.c_str(), headers, 2);
        Pixels p0(depth), p1(colour);
        Imf::OutputPart part0(out, 0);
        part0.setFrameBuffer(p0.fb);
        part0.writePixels(depth.h);
        Imf::TiledOutputPart part1(out, 1);
        part1.setFrameBuffer(p1.fb);
        part1.writeTiles(0, part1.numXTiles() - 1, 0, part1.numYTiles() - 1);
    }
    expect_same_as_read_image(path);
}

TEST(ExrRowReader, BlenderForestIfInstalled) {
    const std::string path = "/usr/share/blender/datafiles/studiolights/world/forest.exr";
    if (!fs::exists(path)) GTEST_SKIP() << "no " << path;
    expect_same_as_read_image(path);
}

TEST(ExrRowReader, RefusesWhatReadImageRefuses) {
    const std::string path = temp_file("cut.exr").string();
    const std::string good = write_file("whole.exr", Layout{});
    fs::copy_file(good, path, fs::copy_options::overwrite_existing);
    fs::resize_file(path, fs::file_size(path) / 2);
    EXPECT_THROW(io::read_image(path), std::runtime_error);
    try {
        io::ExrRowReader r(path);
        std::vector<float> rows(size_t(r.width()) * r.height() * 3);
        r.read(0, r.height(), rows.data());
        ADD_FAILURE() << "a cut file was read";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("cannot read"), std::string::npos) << e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "not a runtime_error: " << e.what();
    }
    EXPECT_THROW(io::ExrRowReader(temp_file("missing.exr").string()), std::runtime_error);
}

// A large source named by IBLBAKE_ROWS_SOURCE (skipped without): decoded in
// preferred bands alone first (time and peak RSS so far printed: what a
// streaming bake's reading costs), then compared with read_image.
TEST(ExrRowReader, LargeSourceFromEnvironment) {
    const char* path = std::getenv("IBLBAKE_ROWS_SOURCE");
    if (!path || !*path) GTEST_SKIP() << "set IBLBAKE_ROWS_SOURCE to an image file";
    std::vector<float> band_rows;
    {
        const auto t0 = std::chrono::steady_clock::now();
        const std::unique_ptr<io::RowReader> reader = io::open_rows(path);  // EXR, HDR, PNG, JPEG, ...
        ASSERT_TRUE(reader) << path << " is read whole, not by rows";
        io::RowReader& r = *reader;
        const int band = r.preferred_band();
        band_rows.resize(size_t(r.width()) * band * 3);
        double sum = 0.0;
        for (int y = 0; y < r.height(); y += band) {
            const int rows = std::min(band, r.height() - y);
            r.read(y, rows, band_rows.data());
            sum += band_rows[size_t(rows - 1) * r.width() * 3];
        }
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        rusage ru{};
        getrusage(RUSAGE_SELF, &ru);
        std::printf("bands of %d rows: %.3f s, peak RSS so far %.1f MB (checksum %g)\n", band, s,
                    ru.ru_maxrss / 1000.0, sum);
        std::vector<float>().swap(band_rows);
    }
    expect_same_as_read_image(path, {1000});  // bands of 1 row decode each block 16 times
}

// The streaming pass a bake will make (docs/design-streaming.md, step 6),
// composed from steps 1 to 5 over a file named by IBLBAKE_STREAM_SOURCE
// (skipped without; IBLBAKE_STREAM_FACE sets mip 0's face, 256 by
// default): the file decoded in bands into a ring that keeps the rows the
// bins need beyond a band, each band cleaned and summarized, the hot heap,
// the finest bins (512 across) and mip 0 fed. Prints the pass's time and
// peak RSS, then checks every result against the whole-image functions.
TEST(StreamingPass, FromEnvironment) {
    const char* path = std::getenv("IBLBAKE_STREAM_SOURCE");
    if (!path || !*path) GTEST_SKIP() << "set IBLBAKE_STREAM_SOURCE to an EXR file";
    const char* face_env = std::getenv("IBLBAKE_STREAM_FACE");
    const int face = face_env ? std::atoi(face_env) : 256, finest = 512, keep_w = 128, max_hot = 1024;
    const double rel = 16.0;
    Cubemap mip0(face);
    SourceSummary summary;
    BinTree tree;
    std::vector<Bin> keep;
    HotSplit hot;
    int w = 0, h = 0;
    {
        const auto t0 = std::chrono::steady_clock::now();
        io::ExrRowReader reader(path);
        w = reader.width(), h = reader.height();
        SummaryStream sum(w, h);
        HotStream hots(w, h, max_hot);
        BinRowStream bins(w, h, finest);
        MirrorStream mirror(mip0, w, h);
        const int keep_rows = std::max(1, bins.max_reach() - 1);  // rows a band keeps from the last
        const int band = std::max(reader.preferred_band(), bins.max_reach());
        const size_t row = size_t(w) * 3;
        std::vector<float> ring(size_t(keep_rows + band) * row);
        std::vector<const float*> table(h, nullptr);
        int have0 = 0, have1 = -1;  // rows in the ring: have0 .. have1, from ring's start
        for (int y0 = 0; y0 < h; y0 += band) {
            const int n = std::min(band, h - y0);
            // Keep the last keep_rows rows at the front, the new band after them.
            const int kept = std::min(keep_rows, have1 - have0 + 1);
            if (kept > 0) std::memmove(ring.data(), ring.data() + size_t(have1 - have0 + 1 - kept) * row, kept * row * sizeof(float));
            have0 = y0 - kept;
            float* fresh = ring.data() + size_t(kept) * row;
            reader.read(y0, n, fresh);
            have1 = y0 + n - 1;
            std::vector<float*> rows(n);
            for (int k = 0; k < n; ++k) rows[k] = fresh + size_t(k) * row;
            sum.add_rows(rows.data(), y0, n);
            hots.add_rows(rows.data(), y0, n);
            std::fill(table.begin(), table.end(), nullptr);
            for (int y = have0; y <= have1; ++y) table[y] = ring.data() + size_t(y - have0) * row;
            ImageView v(nullptr, w, h);
            v.rows = table.data();
            bins.add_rows(v, have0, have1);
            mirror.add_rows(v, have0, have1);
        }
        ASSERT_EQ(bins.pending(), 0);
        ASSERT_EQ(mirror.pending(), 0u);
        summary = sum.finish();
        const std::array<double, 3> mean = channel_means(summary.hot);  // the bake's chroma floor
        BinTreeOptions options;
        options.channel_mean = mean.data();
        tree = bins.finish(mean.data(), &keep, keep_w, options);
        hot = hots.finish(rel, summary.hot);
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        rusage ru{};
        getrusage(RUSAGE_SELF, &ru);
        std::printf("streaming pass (bands of %d rows + %d kept, face %d, finest %d): %.3f s, peak RSS so far %.1f MB\n",
                    band, keep_rows, face, finest, s, ru.ru_maxrss / 1000.0);
    }
    // The whole image, as the bake reads it today.
    io::LoadedImage whole = io::read_image(path);
    SourceSummary ws = summarize_source(whole.image);
    clean_bad_rows(whole.image, ws.scan);
    refresh_summary_rows(ws, whole.image, ws.scan.bad_rows);
    const std::array<double, 3> mean = channel_means(ws.hot);
    EXPECT_EQ(mean, channel_means(summary.hot));
    BinTreeOptions options;
    options.channel_mean = mean.data();
    std::vector<Bin> wkeep;
    const BinTree wt = build_bin_tree(whole.image, finest, &wkeep, keep_w, options);
    ASSERT_EQ(wt.levels.size(), tree.levels.size());
    for (size_t l = 0; l < wt.levels.size(); ++l)
        EXPECT_EQ(0, std::memcmp(wt.levels[l].nodes.data(), tree.levels[l].nodes.data(),
                                 size_t(wt.levels[l].w) * wt.levels[l].h * sizeof(BinNode)));
    ASSERT_EQ(wkeep.size(), keep.size());
    EXPECT_EQ(0, std::memcmp(wkeep.data(), keep.data(), keep.size() * sizeof(Bin)));
    const HotSplit wh = split_hot(whole.image, rel, max_hot, &ws.hot);
    ASSERT_EQ(wh.hot.size(), hot.hot.size());
    EXPECT_EQ(wh.threshold, hot.threshold);
    if (!wh.hot.empty()) {
        EXPECT_EQ(0, std::memcmp(wh.hot.data(), hot.hot.data(), wh.hot.size() * sizeof(RadiancePoint)));
    }
    Cubemap wm(face);
    specular_mirror(wm, whole.image);
    EXPECT_EQ(0, std::memcmp(wm.pixels.data(), mip0.pixels.data(), wm.pixels.size() * sizeof(float)));
}

// PNG (8-bit RGB, RGBA with its straight alpha, 16-bit linear grey), JPEG
// (RGB, grey), and, through OpenImageIO's plugin scanline by scanline,
// Radiance HDR and PFM: the rows are read_image()'s, in bands of any height
// and in any order, with its warnings and its sRGB decode.
TEST(RowReader, FormatsAreReadImagesRows) {
    const fs::path dir = scratch::root() / "rows_formats";
    fs::create_directories(dir);
    Image img = ref::random_smooth_source(160, 80, 5);
    for (float& v : img.pixels) v = std::min(v * 0.3f, 1.0f);  // the 8-bit formats' range
    img.at(10, 10)[0] = 3e4f;  // a bright texel (the float formats keep it)
    std::vector<float> rgba(size_t(160) * 80 * 4), grey(size_t(160) * 80);
    for (size_t t = 0; t < grey.size(); ++t) {
        for (int c = 0; c < 3; ++c) rgba[t * 4 + c] = std::min(img.pixels[t * 3 + c], 1.0f);
        rgba[t * 4 + 3] = float(t % 7) / 6.0f;
        grey[t] = std::min(img.pixels[t * 3 + 1], 1.0f);
    }
    auto file = [&](const std::string& name) { return (dir / name).string(); };
    io::write_png8(file("rgb.png"), 160, 80, 3, {img.pixels.data(), img.pixels.size()});
    io::write_png8(file("rgba.png"), 160, 80, 4, {rgba.data(), rgba.size()});
    io::write_png16(file("grey16.png"), 160, 80, 1, {grey.data(), grey.size()});
    testfiles::write_jpeg(file("rgb.jpg"), img);
    testfiles::write_jpeg(file("grey.jpg"), img, true);
    std::vector<std::string> paths = {file("rgb.png"), file("rgba.png"), file("grey16.png"), file("rgb.jpg"),
                                      file("grey.jpg")};
    if (io::reads_format("hdr")) {
        testfiles::write_radiance(file("s.hdr"), img, "-Y 80 +X 160");
        testfiles::write_pfm(file("s.pfm"), img);
        paths.push_back(file("s.hdr"));
        paths.push_back(file("s.pfm"));
    }
    for (const std::string& path : paths) {
        const io::LoadedImage whole = io::read_image(path);
        std::unique_ptr<io::RowReader> r = io::open_rows(path);
        ASSERT_TRUE(r) << path;
        ASSERT_EQ(r->width(), whole.image.width);
        ASSERT_EQ(r->height(), whole.image.height);
        EXPECT_EQ(r->warnings(), whole.warnings);
        EXPECT_EQ(r->linearised(), whole.linearised) << path;
        EXPECT_GE(r->preferred_band(), 16);
        for (int band : {1, 7, 80, r->preferred_band()})
            for (bool backwards : {false, true}) {
                const std::vector<float> rows = read_in_bands(*r, band, backwards);
                ASSERT_EQ(rows.size(), whole.image.pixels.size());
                EXPECT_EQ(0, std::memcmp(rows.data(), whole.image.pixels.data(), rows.size() * sizeof(float)))
                    << path << ": bands of " << band << (backwards ? ", last first" : "");
            }
        std::vector<float> out(size_t(r->width()) * 3 * 2);
        EXPECT_THROW(r->read(79, 2, out.data()), std::out_of_range);
    }
    EXPECT_TRUE(io::read_image(file("rgb.png")).linearised);
    EXPECT_FALSE(io::read_image(file("grey16.png")).linearised);  // gAMA 1: linear
    if (io::reads_format("hdr")) {
        // The values came through: the PFM's floats exactly, the HDR's within RGBE's 8-bit
        // mantissa (a step of 1/128 of the texel's largest channel at most).
        const io::LoadedImage p = io::read_image(file("s.pfm")), h = io::read_image(file("s.hdr"));
        EXPECT_EQ(0, std::memcmp(p.image.pixels.data(), img.pixels.data(), img.pixels.size() * sizeof(float)));
        for (size_t t = 0; t < img.pixels.size() / 3; t += 31) {
            const float* v = &img.pixels[t * 3];
            const float step = std::max({v[0], v[1], v[2]}) / 128.0f;
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(h.image.pixels[t * 3 + c], v[c], step) << "texel " << t;
        }
    }
    fs::remove_all(dir);
}

// What is read whole: an interlaced PNG (every pass covers every row), a
// Radiance file stored in another order (turned as it is read). A file that
// cannot be read gets read_image's error: a missing file and a cut JPEG
// before any pixel, a cut PNG or HDR at the rows past the cut.
TEST(RowReader, WhatIsReadWholeAndWhatIsRefused) {
    const fs::path dir = scratch::root() / "rows_whole";
    fs::create_directories(dir);
    const Image img = ref::random_smooth_source(64, 32, 2);
    testfiles::write_png_interlaced((dir / "adam7.png").string(), img);
    EXPECT_FALSE(io::open_rows((dir / "adam7.png").string()));
    EXPECT_EQ(io::read_image((dir / "adam7.png").string()).image.width, 64);
    const std::string cut_png = (dir / "cut.png").string(), cut_jpg = (dir / "cut.jpg").string();
    const Image noise = ref::random_smooth_source(256, 128, 9);
    io::write_png8(cut_png, 256, 128, 3, {noise.pixels.data(), noise.pixels.size()});
    fs::resize_file(cut_png, fs::file_size(cut_png) / 2);
    testfiles::write_jpeg(cut_jpg, noise);
    fs::resize_file(cut_jpg, fs::file_size(cut_jpg) / 2);
    EXPECT_THROW(io::open_rows(cut_jpg), std::runtime_error);  // no end-of-image marker: refused as read_image does
    std::unique_ptr<io::RowReader> png = io::open_rows(cut_png);
    ASSERT_TRUE(png);
    std::vector<float> all(size_t(256) * 128 * 3);
    try {
        png->read(0, 128, all.data());
        ADD_FAILURE() << "a cut PNG read to its end";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("cannot read '" + cut_png + "': PNG"), std::string::npos) << e.what();
    }
    EXPECT_THROW(io::read_image(cut_png), std::runtime_error);
    try {
        io::open_rows((dir / "none.exr").string());
        ADD_FAILURE() << "a missing file was opened";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("cannot read '"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("no such file"), std::string::npos) << e.what();
    }
    if (io::reads_format("hdr")) {
        const std::string turned = (dir / "turned.hdr").string();
        testfiles::write_radiance(turned, img, "+Y 32 +X 64");  // bottom row first
        EXPECT_FALSE(io::open_rows(turned));
        EXPECT_EQ(io::read_image(turned).image.width, 64);
        // Cut in the middle of its pixels: the header opens, the rows past the cut fail with the file's name.
        const std::string cut = (dir / "cut.hdr").string();
        testfiles::write_radiance(cut, img, "-Y 32 +X 64");
        fs::resize_file(cut, fs::file_size(cut) - 64 * 4 * 20);
        std::unique_ptr<io::RowReader> r;
        try {
            r = io::open_rows(cut);
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("cannot read '"), std::string::npos) << e.what();
        }
        if (r) {
            std::vector<float> out(size_t(64) * 32 * 3);
            try {
                r->read(0, 32, out.data());
                ADD_FAILURE() << "a cut file read to its end";
            } catch (const std::runtime_error& e) {
                EXPECT_NE(std::string(e.what()).find("cannot read '" + cut), std::string::npos) << e.what();
            }
        }
        EXPECT_THROW(io::read_image(cut), std::runtime_error);
    }
    fs::remove_all(dir);
}
