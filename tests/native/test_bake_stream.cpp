// The streamed bake (issue 28, docs/design-streaming.md step 6):
// compute_bake_stream over bands of rows gives compute_bake's result to the
// bit, whatever the band height, the thread count or the source's oddities;
// it refuses the options that need the whole source, hands back nothing for
// sources the overflow guard must scale, and bake_file streams EXR, HDR, PFM, PNG and JPEG files.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "iblbake/bake/bake.h"
#include "iblbake/io/image_io.h"
#include "iblbake/math/half.h"
#include "iblbake/pipeline/bake_file.h"
#include "iblbake/pipeline/plan.h"
#include "iblbake/pipeline/write.h"
#include "reference.h"
#include "scratch.h"
#include "test_files.h"

using namespace iblbake;
namespace fs = std::filesystem;

namespace {

// An image in memory as bands; counts the reads and checks they come in order, once each.
class ImageBands final : public BandSource {
public:
    ImageBands(const Image& img, int band) : img_(img), band_(band) {}
    int width() const override { return img_.width; }
    int height() const override { return img_.height; }
    int preferred_band() const override { return band_; }
    void read(int y0, int rows, float* out) override {
        EXPECT_EQ(y0, next_) << "rows asked for out of order";
        EXPECT_TRUE(rows >= 1 && y0 + rows <= img_.height);
        next_ = y0 + rows;
        ++reads;
        std::memcpy(out, img_.at(0, y0), size_t(rows) * img_.width * 3 * sizeof(float));
    }
    int reads = 0;

private:
    const Image& img_;
    int band_, next_ = 0;
};

// The same as rows of IEEE halves (has_halves()): the bake makes them floats itself.
class HalfBands final : public BandSource {
public:
    HalfBands(const Image& img, int band) : w_(img.width), h_(img.height), band_(band), h16_(img.pixels.size()) {
        floats_to_half(img.pixels.data(), h16_.data(), h16_.size());
    }
    int width() const override { return w_; }
    int height() const override { return h_; }
    int preferred_band() const override { return band_; }
    void read(int, int, float*) override { ADD_FAILURE() << "read() of a source of halves"; }
    bool has_halves() const override { return true; }
    void read_halves(int y0, int rows, uint16_t* out) override {
        EXPECT_EQ(y0, next_) << "rows asked for out of order";
        EXPECT_TRUE(rows >= 1 && y0 + rows <= h_);
        next_ = y0 + rows;
        if (++reads == fail_at) throw std::runtime_error("cannot read 'x.exr': damaged block");
        std::memcpy(out, h16_.data() + size_t(y0) * w_ * 3, size_t(rows) * w_ * 3 * sizeof(uint16_t));
    }
    // The image the halves are (what the whole-image bake is given).
    Image floats() const {
        Image img(w_, h_);
        halves_to_floats(h16_.data(), img.pixels.data(), h16_.size());
        return img;
    }
    int reads = 0;
    int fail_at = 0;  // the read that throws (0: none)

private:
    int w_, h_, band_, next_ = 0;
    std::vector<uint16_t> h16_;
};

BakeOptions small_options() {
    BakeOptions o;
    o.face_size = 32;
    o.irradiance_size = 8;
    o.lut_size = 16;
    o.irradiance_bins = 32;  // the tree's (finest 128 at face 32) serve: the default 128 would need the whole source
    return o;
}

bool same(const FloatBuffer& a, const FloatBuffer& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// Every output and diagnostic, to the bit (not the timings).
void expect_same(const BakeResult& a, const BakeResult& b, const std::string& what) {
    ASSERT_EQ(a.specular.size(), b.specular.size()) << what;
    for (size_t k = 0; k < a.specular.size(); ++k) EXPECT_TRUE(same(a.specular[k].pixels, b.specular[k].pixels)) << what << " level " << k;
    ASSERT_EQ(a.irradiance.has_value(), b.irradiance.has_value()) << what;
    if (a.irradiance) {
        EXPECT_TRUE(same(a.irradiance->pixels, b.irradiance->pixels)) << what;
    }
    ASSERT_EQ(a.lut.has_value(), b.lut.has_value()) << what;
    if (a.lut) {
        EXPECT_TRUE(same(a.lut->pixels, b.lut->pixels)) << what;
    }
    EXPECT_EQ(0, std::memcmp(&a.sh9, &b.sh9, sizeof(a.sh9))) << what;
    EXPECT_EQ(a.mean_radiance, b.mean_radiance) << what;
    EXPECT_EQ(a.bad_input.pixels, b.bad_input.pixels) << what;
    EXPECT_EQ(a.bad_input.nan, b.bad_input.nan) << what;
    EXPECT_EQ(a.hot_texels, b.hot_texels) << what;
    EXPECT_EQ(a.hot_threshold, b.hot_threshold) << what;
    EXPECT_EQ(a.hot_power_fraction, b.hot_power_fraction) << what;
    EXPECT_EQ(a.specular_base_face, b.specular_base_face) << what;
    EXPECT_EQ(a.samples_per_texel, b.samples_per_texel) << what;
    EXPECT_EQ(a.specular_methods, b.specular_methods) << what;
    EXPECT_EQ(a.specular_levels, b.specular_levels) << what;
    EXPECT_EQ(a.integration_width, b.integration_width) << what;
    EXPECT_EQ(a.warnings, b.warnings) << what;
    ASSERT_EQ(a.extra_specular.size(), b.extra_specular.size()) << what;
    for (size_t k = 0; k < a.extra_specular.size(); ++k) {
        EXPECT_EQ(a.extra_specular[k].face_size, b.extra_specular[k].face_size) << what;
        EXPECT_TRUE(same(a.extra_specular[k].cube.pixels, b.extra_specular[k].cube.pixels)) << what << " extra " << k;
    }
    ASSERT_EQ(a.extra_irradiance.has_value(), b.extra_irradiance.has_value()) << what;
    if (a.extra_irradiance) {
        EXPECT_TRUE(same(a.extra_irradiance->pixels, b.extra_irradiance->pixels)) << what;
    }
}

std::vector<Image> sources() {
    std::vector<Image> s;
    s.push_back(ref::sun_source(256, 128, {0.3, 0.5, 0.4}, 2.0, 2e4f, 0.5f));
    s.push_back(ref::red_sun_source(200, 100, {-0.6, 0.2, 0.1}, 1.0, 1e6f, 0.3f));
    s.push_back(ref::random_smooth_source(300, 150, 7));
    Image bad = ref::random_smooth_source(128, 64, 3);  // NaN, Inf and negative texels, cleaned as they come
    bad.at(5, 0)[0] = std::numeric_limits<float>::quiet_NaN();
    bad.at(70, 31)[1] = std::numeric_limits<float>::infinity();
    bad.at(127, 63)[2] = -4.0f;
    s.push_back(std::move(bad));
    s.push_back(ref::constant_source(1, 1, 2.0f));
    s.push_back(ref::constant_source(3, 2, 0.5f));
    return s;
}

// compute_bake_stream over the bands make_bands(band) makes gives `whole`,
// to the bit: one thread (no reader thread) with bands of 40 rows, two with
// bands of 1, 40 and every row.
template <typename MakeBands>
void expect_streamed_equals(const BakeResult& whole, const BakeOptions& options, MakeBands make_bands,
                            const std::string& what) {
    for (int threads : {1, 2})
        for (int band : {1, 40, 100000}) {
            if (threads == 1 && band != 40) continue;
            BakeOptions o = options;
            o.threads = threads;
            ASSERT_EQ(whole_source_reason(o), "");
            const std::string where = what + " threads " + std::to_string(threads) + " band " + std::to_string(band);
            auto bands = make_bands(band);
            const std::optional<BakeResult> streamed = compute_bake_stream(bands, o);
            ASSERT_TRUE(streamed) << where;
            expect_same(whole, *streamed, where);
            EXPECT_GE(bands.reads, 1);
        }
}

}  // namespace

TEST(StreamedBake, EqualsTheWholeImageBakeToTheBit) {
    std::vector<BakeOptions> options(8, small_options());
    options[1].face_size = 256;  // finest bins 512, the default's
    options[1].irradiance_bins = 128;
    options[2].irradiance = false;
    options[2].extra.specular = {{64, 0.0}, {64, 0.3}, {16, 0.7}};  // an engine's r = 0 level of another size
    options[3].lut = false;
    options[3].mip_count = 3;
    options[4].mip_count = 1;  // mip 0 alone: no tree, the irradiance's own bins
    options[5].irradiance_bins = 128;  // finer than the tree's 128 / 4: its own bins
    options[6].hierarchical.eps = 0.1;  // finest bins 1024
    options[7].mip_count = 1;           // no tree and no irradiance: bins for the SH9 alone
    options[7].irradiance = false;
    const std::vector<Image> srcs = sources();
    for (size_t si = 0; si < srcs.size(); ++si)
        for (size_t oi = 0; oi < options.size(); ++oi) {
            const BakeResult whole = compute_bake(srcs[si], options[oi]);  // the same bits with any thread count
            expect_streamed_equals(whole, options[oi], [&](int band) { return ImageBands(srcs[si], band); },
                                   "source " + std::to_string(si) + " options " + std::to_string(oi));
        }
}

// A source of halves (a HALF EXR's rows): each band read as halves, its
// rows made floats by the pass that reduces them, in a ring of rows (no
// tail copied between bands): the whole-image bake of the same floats, to
// the bit, bad values included.
TEST(StreamedBake, HalvesEqualTheWholeImageBakeToTheBit) {
    std::vector<BakeOptions> options(3, small_options());
    options[1].face_size = 256;  // finest bins 512: bin rows reach across bands of 16 to 40 rows
    options[1].irradiance_bins = 128;
    options[2].mip_count = 1;  // mip 0 alone
    options[2].irradiance_bins = 128;
    const std::vector<Image> srcs = sources();
    for (size_t si = 0; si < srcs.size(); ++si)
        for (size_t oi = 0; oi < options.size(); ++oi) {
            const Image floats = HalfBands(srcs[si], 1).floats();
            const BakeResult whole = compute_bake(floats, options[oi]);
            expect_streamed_equals(whole, options[oi], [&](int band) { return HalfBands(srcs[si], band); },
                                   "source " + std::to_string(si) + " options " + std::to_string(oi));
        }
}

TEST(StreamedBake, StrictRefusesAfterThePassAndProgressIsMonotone) {
    Image bad = ref::random_smooth_source(128, 64, 3);
    bad.at(9, 40)[0] = std::numeric_limits<float>::quiet_NaN();
    BakeOptions o = small_options();
    o.strict = true;
    ImageBands bands(bad, 8);
    EXPECT_THROW(compute_bake_stream(bands, o), BadInputError);
    o.strict = false;
    std::vector<std::pair<std::string, double>> seen;
    ImageBands again(bad, 8);
    compute_bake_stream(again, o, [&](const std::string& s, double f) {
        seen.emplace_back(s, f);
        return true;
    });
    ASSERT_FALSE(seen.empty());
    EXPECT_EQ(seen.back(), (std::pair<std::string, double>("done", 1.0)));
    int reading = 0;
    for (size_t k = 1; k < seen.size(); ++k) {
        EXPECT_GE(seen[k].second, seen[k - 1].second) << seen[k].first;
        reading += seen[k].first == "reading source";
    }
    EXPECT_GE(reading, 4);  // one per band (bands of 16 rows at least)
}

TEST(StreamedBake, CancelDuringThePassStopsReading) {
    const Image src = ref::random_smooth_source(256, 128, 1);
    ImageBands bands(src, 8);
    int calls = 0;
    EXPECT_THROW(compute_bake_stream(bands, small_options(), [&](const std::string& s, double) {
                     return !(s == "reading source" && ++calls == 3);
                 }),
                 Cancelled);
    EXPECT_LE(bands.reads, 5);  // the band being read beside the third, at most
}

namespace {
// The streamed bake of `src` ends with the source's read error, and only it.
void expect_damaged_block(BandSource& src, const BakeOptions& o, const std::string& where) {
    try {
        compute_bake_stream(src, o);
        ADD_FAILURE() << "no error, " << where;
    } catch (const std::runtime_error& e) {
        EXPECT_STREQ(e.what(), "cannot read 'x.exr': damaged block") << where;
    }
}
}  // namespace

// A read that fails (a damaged block) ends the bake with its error, on the
// first read or on the reader thread's, with one thread or two.
TEST(StreamedBake, AFailingReadEndsTheBakeWithItsError) {
    struct Failing final : BandSource {
        const Image& img;
        int fail_at, reads = 0;
        Failing(const Image& i, int f) : img(i), fail_at(f) {}
        int width() const override { return img.width; }
        int height() const override { return img.height; }
        int preferred_band() const override { return 16; }
        void read(int y0, int rows, float* out) override {
            if (++reads == fail_at) throw std::runtime_error("cannot read 'x.exr': damaged block");
            std::memcpy(out, img.at(0, y0), size_t(rows) * img.width * 3 * sizeof(float));
        }
    };
    const Image src = ref::random_smooth_source(256, 128, 2);
    for (int threads : {1, 2})
        for (int fail_at : {1, 2, 5, 8}) {
            BakeOptions o = small_options();
            o.threads = threads;
            Failing f(src, fail_at);
            expect_damaged_block(f, o, "threads " + std::to_string(threads) + " read " + std::to_string(fail_at));
        }
}

// The same for a source of halves, whose reader thread reads ahead while
// the bands before are reduced (BandRing::read_ahead): its error reaches the
// bake, and a cancelled pass stops it within two bands.
TEST(StreamedBake, HalvesReadAheadFailsAndCancelsCleanly) {
    const Image src = ref::random_smooth_source(256, 128, 2);
    for (int threads : {1, 2})
        for (int fail_at : {1, 2, 3, 5, 8}) {
            BakeOptions o = small_options();
            o.threads = threads;
            HalfBands f(src, 16);
            f.fail_at = fail_at;
            expect_damaged_block(f, o, "threads " + std::to_string(threads) + " read " + std::to_string(fail_at));
        }
    HalfBands bands(src, 16);
    int calls = 0;
    EXPECT_THROW(compute_bake_stream(bands, small_options(), [&](const std::string& s, double) {
                     return !(s == "reading source" && ++calls == 3);
                 }),
                 Cancelled);
    EXPECT_LE(bands.reads, 5);  // the three bands reduced and at most two read ahead
}

// bake_file on an EXR with a value of 2^64 or more: the stream hands back
// nothing, the whole image is read and scaled (the overflow guard), the
// progress never goes back.
TEST(StreamedBake, BakeFileFallsBackForTheOverflowGuard) {
    const fs::path dir = scratch::dir("overflow");
    Image src = ref::random_smooth_source(2048, 1024, 4);  // large enough to stream (stream_bytes)
    src.at(300, 200)[1] = 1e30f;
    io::write_exr((dir / "s.exr").string(), src, io::ExrPixel::Float);
    double last = 0.0;
    bool backwards = false;
    const nlohmann::json m = bake_file((dir / "s.exr").string(), dir / "out", make_plan(small_options(), WriteOptions{}),
                                       [&](const std::string&, double f) {
                                           backwards = backwards || f < last;
                                           last = f;
                                           return true;
                                       });
    EXPECT_FALSE(backwards);
    EXPECT_EQ(last, 1.0);
    bool has_sanitize = false;
    for (const auto& t : m["timings"].items()) has_sanitize = has_sanitize || t.key() == "sanitize";
    EXPECT_TRUE(has_sanitize) << "the whole-image path ran";
    const BakeResult whole = compute_bake(io::read_image((dir / "s.exr").string()).image, small_options());
    EXPECT_GT(whole.mean_radiance[1], 1e22);  // the texel's light, scaled back
    EXPECT_NEAR(m["mean_radiance"][1].get<double>() / whole.mean_radiance[1], 1.0, 1e-12);
    fs::remove_all(dir);
}

TEST(StreamedBake, OverflowGuardAndWholeSourceOptionsFallBack) {
    Image huge = ref::constant_source(64, 32, 1.0f);
    huge.at(3, 3)[1] = 1e30f;
    ImageBands bands(huge, 8);
    EXPECT_FALSE(compute_bake_stream(bands, small_options()));  // the whole image, scaled, bakes it
    // And a source whose largest value is below 2^-64 (scaled up, out of the denormals).
    const Image tiny = ref::constant_source(64, 32, 1e-37f);
    ImageBands tiny_bands(tiny, 8);
    EXPECT_FALSE(compute_bake_stream(tiny_bands, small_options()));
    const BakeResult tiny_whole = compute_bake(tiny, small_options());
    for (float v : tiny_whole.specular.back().pixels) ASSERT_NEAR(v / 1e-37f, 1.0f, 1e-3f);
    for (int k = 0; k < 4; ++k) {
        BakeOptions o = small_options();
        if (k == 0) o.rotation = 30.0;
        if (k == 1) o.sun = SunMode::Split;
        if (k == 2) o.specular_method = SpecularMethod::Fis;
        if (k == 3) o.extra.keep_source = true;
        EXPECT_NE(whole_source_reason(o), "") << k;
        ImageBands b(huge, 8);
        EXPECT_THROW(compute_bake_stream(b, o), std::invalid_argument) << k;
        EXPECT_EQ(b.reads, 0);
    }
}

// bake_file streams an EXR (the manifest's timings say "read" without
// "sanitize") and writes the files the whole-image path writes.
// What a streamed bake holds beyond bands and outputs: level 0 of the tree
// (finest 512 at face 256: 512 x 256 bins of 144 bytes), more with finer
// bins or the irradiance's own.
TEST(StreamedBake, StateBytes) {
    BakeOptions o;
    const double tree = 512.0 * 256 * sizeof(Bin), mirror = 52.0 * 256 * 256;
    EXPECT_EQ(stream_state_bytes(o), tree + mirror);
    o.face_size = 64;  // finest 256: the irradiance's 128 x 64 bins of its own
    EXPECT_EQ(stream_state_bytes(o), (256.0 * 128 + 128.0 * 64) * sizeof(Bin) + 52.0 * 64 * 64);
    EXPECT_LT(stream_state_bytes(BakeOptions()), 12.0 * 2048 * 1024);  // (bake_file adds three bands of rows)
    EXPECT_GT(stream_state_bytes(BakeOptions()), 12.0 * 1024 * 512);   // a 1K source is read whole
}

// bake_file streams EXR, Radiance HDR, PFM (through OpenImageIO's plugin,
// when the build has it), PNG and JPEG files: the files it writes are the
// whole-image path's.
class BakeFileStreams : public ::testing::TestWithParam<std::string> {};

TEST_P(BakeFileStreams, WritesTheWholeImagePathsFiles) {
    const std::string ext = GetParam();
    if ((ext == "hdr" || ext == "pfm") && !io::reads_format(ext == "hdr" ? "hdr" : "pnm"))
        GTEST_SKIP() << "no OpenImageIO plugin";
    const fs::path dir = scratch::dir("stream_" + ext);
    // 2048 x 1024: its floats (25 MB) outweigh the bake's state and three bands (stream_bytes), so it streams.
    Image src = ref::sun_source(2048, 1024, {0.2, 0.5, 0.4}, 2.0, 1e4f, 0.5f);
    const std::string path = (dir / ("s." + ext)).string();
    if (ext == "exr") {
        src.at(100, 100)[0] = std::numeric_limits<float>::quiet_NaN();
        io::write_exr(path, src, io::ExrPixel::Float);
    } else if (ext == "hdr") {
        testfiles::write_radiance(path, src, "-Y 1024 +X 2048");
    } else if (ext == "png") {  // 8-bit sRGB: the values clamped to 1, decoded as read_image decodes them
        io::write_png8(path, src.width, src.height, 3, {src.pixels.data(), src.pixels.size()});
    } else if (ext == "jpg") {
        testfiles::write_jpeg(path, src);
    } else {
        src.at(100, 100)[0] = std::numeric_limits<float>::quiet_NaN();
        testfiles::write_pfm(path, src);
    }
    WriteOptions wo;
    wo.png = true;
    const BakeOptions o = small_options();
    const nlohmann::json m = bake_file(path, dir / "streamed", make_plan(o, wo));
    bool has_sanitize = false;
    for (const auto& t : m["timings"].items()) has_sanitize = has_sanitize || t.key() == "sanitize";
    EXPECT_TRUE(m["timings"].contains("read"));
    EXPECT_FALSE(has_sanitize) << m["timings"].dump();  // the whole-image path's stage: not run
    EXPECT_EQ(m["bad_input"]["nan"], ext == "exr" || ext == "pfm" ? 1 : 0);
    EXPECT_EQ(m["source"]["linearised_from_srgb"], ext == "png" || ext == "jpg") << m["source"].dump();
    // The same files as the whole-image path's: compute_bake of the image the file holds, through the same writer.
    {
        const BakePlan plan = make_plan(o, wo);
        BakeWriter writer(dir / "whole", plan);
        const BakeResult r = compute_bake(io::read_image(path).image, plan.bake, {}, nullptr, &writer);
        SourceInfo info;
        info.width = src.width, info.height = src.height;
        writer.finish(r, info);
    }
    for (const auto& e : fs::directory_iterator(dir / "streamed")) {
        if (e.path().filename() == "manifest.json") continue;
        std::ifstream a(e.path(), std::ios::binary), b(dir / "whole" / e.path().filename(), std::ios::binary);
        const std::string da((std::istreambuf_iterator<char>(a)), {}), db((std::istreambuf_iterator<char>(b)), {});
        EXPECT_EQ(da, db) << e.path().filename();
    }
    fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(StreamedBake, BakeFileStreams, ::testing::Values("exr", "hdr", "pfm", "png", "jpg"));
