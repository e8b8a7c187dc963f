// The pipeline end to end: files, manifest, atomic output, bad input, CLI.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "iblbake/bake/lut_cache.h"
#include "iblbake/ibl/specular.h"
#include "iblbake/image/encode.h"
#include "iblbake/io/hash.h"
#include "iblbake/io/image_io.h"
#include "iblbake/math/color.h"
#include "iblbake/pipeline/bake_file.h"
#include "iblbake/pipeline/write.h"
#include "reference.h"
#include "scratch.h"

using namespace iblbake;
namespace fs = std::filesystem;

namespace {
fs::path temp_dir(const std::string& name) {
    return scratch::dir(name);
}

BakeOptions small_options() {
    BakeOptions o;
    o.face_size = 16;
    o.irradiance_size = 8;
    o.lut_size = 16;
    return o;
}

fs::path write_source(const fs::path& dir, const Image& img) {
    const fs::path p = dir / "source.exr";
    io::write_exr(p.string(), img, io::ExrPixel::Float);
    return p;
}

nlohmann::json read_json(const fs::path& p) {
    std::ifstream f(p);
    return nlohmann::json::parse(f);
}

int run_cli(const std::string& args) {
    const int rc = std::system((std::string(IBLBAKE_CLI) + " " + args + " >/dev/null 2>&1").c_str());
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
}  // namespace

TEST(Bake, WritesEveryFileTheManifestNames) {
    const fs::path dir = temp_dir("files");
    const fs::path src = write_source(dir, ref::random_smooth_source(64, 32, 1));
    WriteOptions wo;
    wo.png = true;
    const nlohmann::json m = bake_file(src.string(), dir / "out", make_plan(small_options(), wo));
    for (const char* key : {"contract", "source", "convention", "layout", "irradiance", "specular", "brdf_lut", "sh9",
                            "bad_input", "skipped", "encodings", "timings"})
        EXPECT_TRUE(m.contains(key)) << key;
    EXPECT_EQ(m["contract"], 1);
    EXPECT_EQ(m["convention"], "opengl-y-up");
    EXPECT_EQ(m["layout"], "hcross");
    EXPECT_EQ(m["source"]["width"], 64);
    EXPECT_EQ(m["source"]["sha256"].get<std::string>().size(), 64u);
    EXPECT_EQ(m["specular"].size(), 5u);  // 16, 8, 4, 2, 1
    EXPECT_EQ(m["specular"][4]["roughness"], 1.0);
    EXPECT_EQ(m["sh9"].size(), 3u);
    EXPECT_EQ(m["sh9"][0].size(), 9u);
    for (const auto& [file, enc] : m["encodings"].items()) EXPECT_TRUE(fs::exists(dir / "out" / file)) << file;
    EXPECT_EQ(m["encodings"]["brdf_lut.exr"], "float");
    EXPECT_EQ(m["encodings"]["irradiance.exr"], "half");
    EXPECT_EQ(m["encodings"]["brdf_lut.png"], "unorm16");
    EXPECT_EQ(read_json(dir / "out" / "manifest.json"), m);
    // The irradiance cross reads back as 4N x 3N with the values computed.
    const io::LoadedImage irr = io::read_image((dir / "out" / "irradiance.exr").string());
    EXPECT_EQ(irr.image.width, 32);
    EXPECT_EQ(irr.image.height, 24);
    // No staging folders left behind.
    for (const auto& e : fs::directory_iterator(dir)) EXPECT_EQ(e.path().filename().string().find(".out"), std::string::npos);
}

// A library run hashes each world for its content hash and hands that
// digest to bake_file, which gives it to the manifest while the file keeps
// the stamp it had then (before and after decoding) and hashes it again
// otherwise. A marker digest shows which one the manifest got. Both the
// whole-image (64 x 32) and the streamed (1024 x 512) bake.
TEST(Bake, CallersDigestIsUsedWhileTheFileKeepsItsStamp) {
    for (const int w : {64, 1024}) {
        SCOPED_TRACE(w);
        const fs::path dir = temp_dir("digest");
        const fs::path src = write_source(dir, ref::random_smooth_source(w, w / 2, 3));
        const BakePlan plan = make_plan(small_options(), {});
        auto bake = [&](const io::FileDigest* d, const ProgressFn& progress = {}) {
            return bake_file(src.string(), dir / "out", plan, progress, nullptr, d)["source"]["sha256"]
                .get<std::string>();
        };
        const std::string truth = io::sha256_file(src.string());
        // Written a moment ago: a change in the same clock tick would keep the stamp.
        EXPECT_FALSE(io::sha256_file_stamped(src.string()).stamp);
        std::this_thread::sleep_for(std::chrono::milliseconds(150));
        const io::FileDigest d = io::sha256_file_stamped(src.string());
        ASSERT_TRUE(d.stamp);
        EXPECT_EQ(d.sha256, truth);
        EXPECT_EQ(io::stamp_of(src.string()), d.stamp);

        io::FileDigest marked = d;
        marked.sha256 = std::string(64, 'a');
        EXPECT_EQ(bake(&marked), marked.sha256);  // reused: not hashed again
        EXPECT_EQ(bake(nullptr), truth);
        io::FileDigest other = marked;
        other.stamp->mtime_ns += 1;
        EXPECT_EQ(bake(&other), truth);
        io::FileDigest racy = marked;
        racy.stamp.reset();
        EXPECT_EQ(bake(&racy), truth);
        // Touched while it is decoded: the stamp after decoding differs.
        bool touched = false;
        EXPECT_EQ(bake(&marked,
                       [&](const std::string&, double) {
                           if (!touched) fs::last_write_time(src, fs::last_write_time(src) - std::chrono::hours(1));
                           touched = true;
                           return true;
                       }),
                  truth);
        EXPECT_TRUE(touched);
        // Rewritten since it was hashed: its new bytes' digest.
        write_source(dir, ref::random_smooth_source(w, w / 2, 4));
        EXPECT_EQ(bake(&marked), io::sha256_file(src.string()));
        EXPECT_NE(io::sha256_file(src.string()), truth);
    }
}

TEST(Bake, FailedBakeKeepsEarlierOne) {
    const fs::path dir = temp_dir("atomic");
    const fs::path src = write_source(dir, ref::random_smooth_source(64, 32, 2));
    bake_file(src.string(), dir / "out", make_plan(small_options(), {}));
    const auto before = read_json(dir / "out" / "manifest.json");
    // Missing, empty and corrupt sources: clear errors, old bake intact.
    EXPECT_THROW(bake_file((dir / "missing.exr").string(), dir / "out", make_plan(small_options(), {})), std::runtime_error);
    std::ofstream(dir / "empty.exr").close();
    EXPECT_THROW(bake_file((dir / "empty.exr").string(), dir / "out", make_plan(small_options(), {})), std::runtime_error);
    { std::ofstream f(dir / "corrupt.exr"); f << "this is not an EXR file at all, just text"; }
    try {
        bake_file((dir / "corrupt.exr").string(), dir / "out", make_plan(small_options(), {}));
        FAIL() << "corrupt file accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("corrupt.exr"), std::string::npos) << e.what();
    }
    // A cancelled bake leaves it intact too.
    EXPECT_THROW(bake_file(src.string(), dir / "out", make_plan(small_options(), {}),
                           [](const std::string&, double f) { return f < 0.3; }),
                 Cancelled);
    EXPECT_EQ(read_json(dir / "out" / "manifest.json"), before);
    int entries = 0;
    for (const auto& e : fs::directory_iterator(dir)) entries += e.path().filename().string().rfind(".out", 0) == 0;
    EXPECT_EQ(entries, 0) << "staging folder left behind";
}

TEST(Bake, BadPixelsCountedZeroedOrRefused) {
    Image img = ref::constant_source(32, 16, 1.0f);
    img.at(1, 1)[0] = std::numeric_limits<float>::quiet_NaN();
    img.at(2, 2)[1] = std::numeric_limits<float>::infinity();
    img.at(3, 3)[2] = -5.0f;
    const BakeResult r = compute_bake(img, small_options());
    EXPECT_EQ(r.bad_input.nan, 1u);
    EXPECT_EQ(r.bad_input.inf, 1u);
    EXPECT_EQ(r.bad_input.negative, 1u);
    EXPECT_EQ(r.bad_input.pixels, 3u);
    for (const auto& lvl : r.specular)
        for (float v : lvl.pixels) ASSERT_TRUE(std::isfinite(v));
    for (float v : r.irradiance->pixels) ASSERT_TRUE(std::isfinite(v));
    BakeOptions strict = small_options();
    strict.strict = true;
    EXPECT_THROW(compute_bake(img, strict), BadInputError);
}

TEST(Bake, HugeValuesGoToFullFloat) {
    const fs::path dir = temp_dir("huge");
    const fs::path src = write_source(dir, ref::sun_source(64, 32, {0, 0, 1}, 20.0, 1e6f, 1.0f));
    const nlohmann::json m = bake_file(src.string(), dir / "out", make_plan(small_options(), {}));
    EXPECT_EQ(m["encodings"]["specular_0.exr"], "float");
}

TEST(Bake, TinySourcesAndSizes) {
    for (auto [w, h] : {std::pair{1, 1}, {2, 1}, {3, 7}}) {
        Image img(w, h);
        for (size_t k = 0; k < img.pixels.size(); ++k) img.pixels[k] = float(1 + k % 5);
        for (int face : {1, 2, 5}) {
            BakeOptions o;
            o.face_size = face;
            o.irradiance_size = face;
            o.lut_size = 1;
            const BakeResult r = compute_bake(img, o);
            for (const auto& lvl : r.specular)
                for (float v : lvl.pixels) ASSERT_TRUE(std::isfinite(v) && v >= 0) << w << "x" << h << " face " << face;
            for (float v : r.irradiance->pixels) ASSERT_TRUE(std::isfinite(v) && v > 0);
        }
    }
}

TEST(Bake, SkippedOutputsAreRecorded) {
    BakeOptions o = small_options();
    o.specular = false;
    o.skip_reasons.push_back({"specular", "no glossy material in the scene"});
    o.lut = false;
    const BakeResult r = compute_bake(ref::constant_source(16, 8, 1.0f), o);
    ASSERT_EQ(r.skipped.size(), 2u);
    EXPECT_EQ(r.skipped[0].why, "no glossy material in the scene");
    EXPECT_EQ(r.skipped[1].why, "disabled by option");
    EXPECT_TRUE(r.specular.empty());
}

TEST(Bake, InvalidOptionsAreRejected) {
    BakeOptions o;
    o.face_size = 0;
    EXPECT_THROW(o.validate(), std::invalid_argument);
    o = {};
    o.specular_base_face = 3;
    EXPECT_THROW(o.validate(), std::invalid_argument);
}

TEST(Cli, ExitCodes) {
    const fs::path dir = temp_dir("cli");
    const fs::path src = write_source(dir, ref::random_smooth_source(32, 16, 4));
    EXPECT_EQ(run_cli("--help"), 0);
    EXPECT_EQ(run_cli("bake --help"), 0);
    EXPECT_NE(run_cli("bake"), 0);
    EXPECT_NE(run_cli("bake " + (dir / "missing.exr").string() + " -o " + (dir / "o").string()), 0);
    EXPECT_NE(run_cli("bake " + src.string() + " -o " + (dir / "o").string() + " --lut-model nope"), 0);
    EXPECT_NE(run_cli("bake " + src.string() + " -o " + (dir / "o").string() + " --face-size -3"), 0);
    EXPECT_FALSE(fs::exists(dir / "o"));
    EXPECT_EQ(run_cli("bake " + src.string() + " -o " + (dir / "o").string() +
                      " --face-size 8 --irradiance-size 4 --lut-size 8 --format exr,png"),
              0);
    EXPECT_TRUE(fs::exists(dir / "o" / "manifest.json"));
    EXPECT_TRUE(fs::exists(dir / "o" / "specular_0.png"));
}

TEST(LutCache, SecondBakeReadsTheFirstOnesLut) {
    const fs::path dir = temp_dir("lutcache");
    FileLutCache cache(dir / "cache");
    BakeOptions o = small_options();
    o.specular = false;
    o.irradiance = false;
    const BakeResult a = compute_bake(ref::constant_source(8, 4, 1.0f), o, {}, &cache);
    EXPECT_FALSE(a.lut_from_cache);
    const BakeResult b = compute_bake(ref::constant_source(8, 4, 2.0f), o, {}, &cache);
    EXPECT_TRUE(b.lut_from_cache);
    EXPECT_EQ(a.lut->pixels, b.lut->pixels);  // exact: full-float round trip
    // The pixels' sha256 comes with the table (stored, then found): the key
    // of its encoded files, not hashed again; without a cache it is unknown.
    const std::string sha = io::sha256_bytes(a.lut->pixels.data(), a.lut->pixels.size() * sizeof(float));
    EXPECT_EQ(a.lut_sha256, sha);
    EXPECT_EQ(b.lut_sha256, sha);
    EXPECT_EQ(encoded_lut_key_of(sha, "exr"), encoded_lut_key(*a.lut, "exr"));
    EXPECT_TRUE(compute_bake(ref::constant_source(8, 4, 1.0f), o).lut_sha256.empty());
    // Another model or quality is another entry.
    o.lut_model = LutModel::HeightCorrelated;
    EXPECT_FALSE(compute_bake(ref::constant_source(8, 4, 1.0f), o, {}, &cache).lut_from_cache);
    // A damaged entry is a miss and gets replaced.
    const fs::path entry = dir / "cache" / (lut_cache_key(o.lut_size, o.lut_model, o.lut_quality) + ".lut");
    ASSERT_TRUE(fs::exists(entry));
    const auto good_size = fs::file_size(entry);
    { std::ofstream f(entry, std::ios::trunc); f << "junk"; }
    const BakeResult c = compute_bake(ref::constant_source(8, 4, 1.0f), o, {}, &cache);
    EXPECT_FALSE(c.lut_from_cache);
    EXPECT_TRUE(compute_bake(ref::constant_source(8, 4, 1.0f), o, {}, &cache).lut_from_cache);
    // A truncated or over-long entry is a miss too.
    for (auto size : {good_size - 4, good_size + 4}) {
        fs::resize_file(entry, size);
        EXPECT_FALSE(compute_bake(ref::constant_source(8, 4, 1.0f), o, {}, &cache).lut_from_cache) << size;
        EXPECT_EQ(fs::file_size(entry), good_size);
    }
}

TEST(LutCache, SecondBakeCopiesTheLutFilesTheFirstEncoded) {
    const fs::path dir = temp_dir("lutfiles");
    const fs::path src = write_source(dir, ref::random_smooth_source(32, 16, 5));
    FileLutCache cache(dir / "cache");
    WriteOptions wo;
    wo.png = true;
    auto bytes = [](const fs::path& p) {
        std::ifstream f(p, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(f), {});
    };
    auto entries = [&] {
        std::vector<fs::path> e;
        for (const auto& it : fs::directory_iterator(dir / "cache"))
            if (it.path().extension() == ".enc") e.push_back(it.path());
        std::sort(e.begin(), e.end());
        return e;
    };
    bake_file(src.string(), dir / "a", make_plan(small_options(), wo), {}, &cache);
    const std::vector<fs::path> enc = entries();
    ASSERT_EQ(enc.size(), 2u);  // the EXR's and the PNG's
    bake_file(src.string(), dir / "b", make_plan(small_options(), wo), {}, &cache);
    EXPECT_EQ(entries(), enc);
    for (const char* f : {"brdf_lut.exr", "brdf_lut.png"}) {
        EXPECT_EQ(bytes(dir / "a" / f), bytes(dir / "b" / f)) << f;
        EXPECT_FALSE(bytes(dir / "b" / f).empty()) << f;
    }
    // A damaged entry is a miss: the file is encoded again (the same bytes)
    // and the entry replaced.
    for (const fs::path& e : enc) {
        std::string b = bytes(e);
        b.back() ^= 1;
        std::ofstream(e, std::ios::binary | std::ios::trunc) << b;
        EXPECT_FALSE(cache.copy_encoded(e.stem().string(), dir / "x"));
        EXPECT_FALSE(fs::exists(dir / "x")) << "a damaged entry's bytes were left behind";
    }
    bake_file(src.string(), dir / "c", make_plan(small_options(), wo), {}, &cache);
    for (const char* f : {"brdf_lut.exr", "brdf_lut.png"}) EXPECT_EQ(bytes(dir / "a" / f), bytes(dir / "c" / f)) << f;
    for (const fs::path& e : enc) EXPECT_TRUE(cache.copy_encoded(e.stem().string(), dir / "x")) << e;
    // The copy is what the entry holds (the control that bakes do copy),
    // and the key is the table's pixels and the encoding.
    { std::ofstream(dir / "hello") << "hello"; }
    cache.store_encoded("k", dir / "hello");
    std::string sha;
    ASSERT_TRUE(cache.copy_encoded("k", dir / "copy", &sha));
    EXPECT_EQ(bytes(dir / "copy"), "hello");
    EXPECT_EQ(sha, io::sha256_file((dir / "copy").string()));  // the copy's own digest, taken on the way
    EXPECT_FALSE(cache.copy_encoded("other", dir / "copy"));
    Image lut(4, 4);
    const std::string k = encoded_lut_key(lut, "exr");
    EXPECT_NE(k, encoded_lut_key(lut, "png"));
    lut.pixels[7] = 1.0f;
    EXPECT_NE(k, encoded_lut_key(lut, "exr"));
}

TEST(Io, CrossStreamedInBandsReadsBackExactly) {
    // A face of 50: the 150-row cross goes out in bands of 64, 64 and 22 rows.
    const int n = 50;
    Cubemap cube(n);
    for (size_t k = 0; k < cube.pixels.size(); ++k) cube.pixels[k] = float(k % 977) * 0.25f;  // exact in half
    const std::vector<float> whole = cube_to_hcross_rgba(cube);
    std::vector<float> band(size_t(4) * n * 4 * 37);
    hcross_rgba_rows(cube, 40, 37, band.data());  // any band is the same slice of the whole cross
    EXPECT_TRUE(std::equal(band.begin(), band.end(), whole.begin() + size_t(40) * 4 * n * 4));
    const fs::path dir = temp_dir("bands");
    for (io::ExrPixel px : {io::ExrPixel::Half, io::ExrPixel::Float}) {
        const std::string path = (dir / (px == io::ExrPixel::Half ? "h.exr" : "f.exr")).string();
        io::write_exr_rows(path, 4 * n, 3 * n, 4, px,
                           [&](int y0, int rows, float* out) { hcross_rgba_rows(cube, y0, rows, out); });
        const io::LoadedImage li = io::read_image(path);
        EXPECT_EQ(hcross_to_cube(li.image).pixels, cube.pixels);
    }
    // PNG in bands, encoded band by band: the same bytes as from the whole cross.
    auto bytes = [](const fs::path& p) {
        std::ifstream f(p, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(f), {});
    };
    for (float exposure : {-8.0f, 0.0f}) {
        io::write_png8((dir / "whole.png").string(), 4 * n, 3 * n, 4, encode_rgbm(whole, exposure, 8.0f));
        io::write_png8_rows((dir / "bands.png").string(), 4 * n, 3 * n, 4, [&](int y0, int rows, float* out) {
            hcross_rgba_rows(cube, y0, rows, out);
            encode_rgbm_in_place(out, size_t(rows) * 4 * n * 4, exposure, 8.0f);
        });
        EXPECT_EQ(bytes(dir / "whole.png"), bytes(dir / "bands.png")) << exposure;
    }
}

TEST(Io, ReadsHdrPngAndGreyImages) {
    const fs::path dir = temp_dir("formats");
    Image img = ref::random_smooth_source(16, 8, 3);
    // Radiance .hdr keeps floats (RGBE: about 1 % precision).
    io::write_exr((dir / "a.exr").string(), img, io::ExrPixel::Float);
    const std::string hdr = (dir / "a.hdr").string();
    ASSERT_EQ(std::system(("oiiotool " + (dir / "a.exr").string() + " -o " + hdr + " >/dev/null 2>&1").c_str()), 0);
    const io::LoadedImage h = io::read_image(hdr);
    EXPECT_FALSE(h.linearised);
    EXPECT_NEAR(h.image.at(3, 4)[1] / img.at(3, 4)[1], 1.0, 0.02);
    // A one-channel 8-bit PNG: grey expanded to RGB, linearised from sRGB.
    std::vector<float> grey(16 * 8, 0.5f);
    io::write_png8((dir / "g.png").string(), 16, 8, 1, grey);
    const io::LoadedImage g = io::read_image((dir / "g.png").string());
    EXPECT_TRUE(g.linearised);
    EXPECT_EQ(g.source_channels, 1);
    EXPECT_NEAR(g.image.at(5, 5)[0], srgb_to_linear(128.0f / 255.0f), 1e-4);
    EXPECT_EQ(g.image.at(5, 5)[0], g.image.at(5, 5)[2]);
}

TEST(Bake, RefusesToReplaceWhatIsNotABake) {
    const fs::path dir = temp_dir("refuse");
    const fs::path src = write_source(dir, ref::constant_source(16, 8, 1.0f));
    fs::create_directories(dir / "precious");
    { std::ofstream f(dir / "precious" / "notes.txt"); f << "keep me"; }
    EXPECT_THROW(bake_file(src.string(), dir / "precious", make_plan(small_options(), {})), std::runtime_error);
    EXPECT_TRUE(fs::exists(dir / "precious" / "notes.txt"));
    // The folder holding the source, the current folder, an empty path: refused.
    EXPECT_THROW(bake_file(src.string(), dir, make_plan(small_options(), {})), std::runtime_error);
    EXPECT_THROW(bake_file(src.string(), fs::current_path(), make_plan(small_options(), {})), std::runtime_error);
    EXPECT_THROW(bake_file(src.string(), "", make_plan(small_options(), {})), std::runtime_error);
    // An empty folder and an earlier bake are fine.
    fs::create_directories(dir / "empty");
    EXPECT_NO_THROW(bake_file(src.string(), dir / "empty", make_plan(small_options(), {})));
    EXPECT_NO_THROW(bake_file(src.string(), dir / "empty", make_plan(small_options(), {})));
}

TEST(Bake, StaleStagingFromKilledBakesIsRemoved) {
    const fs::path dir = temp_dir("stale");
    const fs::path src = write_source(dir, ref::constant_source(16, 8, 1.0f));
    // A staging folder whose process is gone (pid 999999999 does not exist).
    fs::create_directories(dir / ".out.iblbake-999999999-deadbeef");
    bake_file(src.string(), dir / "out", make_plan(small_options(), {}));
    EXPECT_FALSE(fs::exists(dir / ".out.iblbake-999999999-deadbeef"));
}

TEST(Bake, HugeFiniteValuesNeverOverflow) {
    for (float v : {1e35f, 3.0e38f}) {
        Image img = ref::constant_source(64, 32, 1.0f);
        img.at(10, 10)[0] = v;  // one enormous texel
        Image all = ref::constant_source(32, 16, v);
        for (const Image* src : {&img, &all}) {
            const BakeResult r = compute_bake(*src, small_options());
            for (const auto& lvl : r.specular)
                for (float x : lvl.pixels) ASSERT_TRUE(std::isfinite(x)) << v;
            for (float x : r.irradiance->pixels) ASSERT_TRUE(std::isfinite(x)) << v;
        }
        const BakeResult r = compute_bake(all, small_options());
        EXPECT_NEAR(r.irradiance->pixels[0] / v, 1.0, 1e-3);
        EXPECT_NEAR(r.specular[2].pixels[0] / v, 1.0, 1e-3);
    }
}

TEST(Bake, FilesAreByteIdenticalAcrossThreadCounts) {
    const fs::path dir = temp_dir("bytes");
    const fs::path src = write_source(dir, ref::sun_source(128, 64, {0.2, 0.5, 0.4}, 2.0, 1e4f, 0.5f));
    WriteOptions wo;
    wo.png = true;
    BakeOptions o = small_options();
    o.threads = 1;
    bake_file(src.string(), dir / "one", make_plan(o, wo));
    o.threads = 2;
    bake_file(src.string(), dir / "two", make_plan(o, wo));
    for (const auto& e : fs::directory_iterator(dir / "one")) {
        if (e.path().filename() == "manifest.json") continue;  // holds timings
        std::ifstream a(e.path(), std::ios::binary), b(dir / "two" / e.path().filename(), std::ios::binary);
        const std::string da((std::istreambuf_iterator<char>(a)), {}), db((std::istreambuf_iterator<char>(b)), {});
        EXPECT_EQ(da, db) << e.path().filename();
    }
}

TEST(Bake, WriteOptionsAreValidated) {
    WriteOptions wo;
    wo.exposure = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(wo.validate(), std::invalid_argument);
    wo = {};
    wo.rgbm_range = 0.0f;
    EXPECT_THROW(wo.validate(), std::invalid_argument);
    wo = {};
    wo.exr = false;
    EXPECT_THROW(wo.validate(), std::invalid_argument);
}

TEST(Io, DataWindowIsPlacedInTheDisplayWindow) {
    const fs::path dir = temp_dir("window");
    io::write_exr((dir / "full.exr").string(), ref::constant_source(64, 32, 1.0f), io::ExrPixel::Float);
    const std::string crop = (dir / "crop.exr").string();
    ASSERT_EQ(std::system(("oiiotool " + (dir / "full.exr").string() + " --crop 64x16+0+0 -o " + crop +
                           " >/dev/null 2>&1").c_str()),
              0);
    const io::LoadedImage li = io::read_image(crop);
    EXPECT_EQ(li.image.width, 64);
    EXPECT_EQ(li.image.height, 32);
    EXPECT_EQ(li.image.at(5, 3)[0], 1.0f);   // top half: data
    EXPECT_EQ(li.image.at(5, 20)[0], 0.0f);  // bottom half: outside the data window
}

TEST(Bake, LevelRangeBakesOnlyThoseLevelsAndNamesTheRest) {
    BakeOptions o = small_options();  // 16 -> 5 levels
    o.lut = false;
    o.first_level = 1;
    o.last_level = 3;
    const BakeResult part = compute_bake(ref::random_smooth_source(64, 32, 5), o);
    BakeOptions all = o;
    all.first_level = 0;
    all.last_level = -1;
    const BakeResult full = compute_bake(ref::random_smooth_source(64, 32, 5), all);
    ASSERT_EQ(part.specular_levels, (std::vector<int>{1, 2, 3}));
    for (size_t i = 0; i < part.specular.size(); ++i) {
        const int m = part.specular_levels[i];
        EXPECT_DOUBLE_EQ(part.roughness[i], full.roughness[m]);  // r_m still counts all M levels
        ASSERT_EQ(part.specular[i].size, full.specular[m].size);
        for (size_t k = 0; k < part.specular[i].pixels.size(); ++k)
            EXPECT_NEAR(part.specular[i].pixels[k], full.specular[m].pixels[k], 2e-3f * (1.0f + full.specular[m].pixels[k]));
    }
    bool named = false;
    for (const Skip& s : part.skipped) named |= s.what == "specular levels 0-0, 4-4";
    EXPECT_TRUE(named);
    const fs::path dir = temp_dir("levels");
    const nlohmann::json m = write_bake(part, dir / "out", make_plan(o, WriteOptions{}), SourceInfo{});
    EXPECT_EQ(m["specular"][0]["level"], 1);
    EXPECT_TRUE(fs::exists(dir / "out" / "specular_3.exr"));
    EXPECT_FALSE(fs::exists(dir / "out" / "specular_0.exr"));
    o.last_level = 5;
    EXPECT_THROW(o.validate(), std::invalid_argument);
    fs::remove_all(dir);
}

TEST(Bake, ConstantWorldInClosedFormMatchesTheIntegrators) {
    BakeOptions o = small_options();
    o.lut = false;
    const std::array<float, 3> rgb{0.25f, 1.0f, 3.0f};
    const BakeResult c = compute_constant_bake(rgb, o);
    Image src(32, 16);
    for (size_t k = 0; k < src.pixels.size(); ++k) src.pixels[k] = rgb[k % 3];
    const BakeResult g = compute_bake(src, o);
    ASSERT_TRUE(c.irradiance && g.irradiance);
    for (size_t k = 0; k < c.irradiance->pixels.size(); ++k)
        EXPECT_NEAR(c.irradiance->pixels[k], g.irradiance->pixels[k], 1e-3f * rgb[k % 3]);
    ASSERT_EQ(c.specular.size(), g.specular.size());
    for (size_t m = 0; m < c.specular.size(); ++m)
        for (size_t k = 0; k < c.specular[m].pixels.size(); ++k)
            EXPECT_NEAR(c.specular[m].pixels[k], g.specular[m].pixels[k], 1e-3f * rgb[k % 3]);
    for (int ch = 0; ch < 3; ++ch)
        for (int i = 0; i < 9; ++i) EXPECT_NEAR(c.sh9[ch][i], g.sh9[ch][i], 1e-5 * (1 + std::fabs(g.sh9[ch][i])));
    // A NaN colour is bad input like any other.
    const BakeResult bad = compute_constant_bake({std::nanf(""), 1.0f, 1.0f}, o);
    EXPECT_EQ(bad.bad_input.nan, 1u);
    EXPECT_EQ(bad.irradiance->pixels[0], 0.0f);
    o.strict = true;
    EXPECT_THROW(compute_constant_bake({-1.0f, 1.0f, 1.0f}, o), BadInputError);
}

TEST(Bake, ManifestExtraKeysAreAddedButNeverReplaceTheContract) {
    BakeOptions o = small_options();
    const BakeResult r = compute_constant_bake({1, 1, 1}, o);
    WriteOptions wo;
    wo.manifest_extra = {{"blender", {{"world_path", "plain colour"}}}};
    const nlohmann::json m = make_manifest(r, make_plan(o, wo), SourceInfo{}, nlohmann::json::object());
    EXPECT_EQ(m["blender"]["world_path"], "plain colour");
    EXPECT_EQ(m["contract"], 1);
    wo.manifest_extra = {{"sh9", 0}};
    EXPECT_THROW(make_manifest(r, make_plan(o, wo), SourceInfo{}, nlohmann::json::object()), std::invalid_argument);
}

// The manifest says which specular kernel ran; IBLBAKE_ISA=baseline forces
// the baseline one in the CLI.
TEST(Cli, SpecularKernelIsRecordedAndCanBeForced) {
    const fs::path dir = temp_dir("kernel_isa");
    const fs::path src = write_source(dir, ref::sun_source(128, 64, {0.2, 0.5, 0.4}, 2.0, 1e4f, 0.5f));
    const std::string common = src.string() + " --face-size 16 --irradiance-size 8 --lut-size 16 -o ";
    ASSERT_EQ(run_cli("bake " + common + (dir / "best").string()), 0);
    ASSERT_EQ(std::system(("IBLBAKE_ISA=baseline " + std::string(IBLBAKE_CLI) + " bake " + common +
                           (dir / "base").string() + " >/dev/null 2>&1")
                              .c_str()),
              0);
    const nlohmann::json best = read_json(dir / "best" / "manifest.json");
    const nlohmann::json base = read_json(dir / "base" / "manifest.json");
    EXPECT_EQ(base["specular_kernel"], "baseline");
    ASSERT_TRUE(set_specular_kernel_isa(""));
    EXPECT_EQ(best["specular_kernel"], specular_kernel_isa());  // the best this CPU has
    EXPECT_NE(base["specular"][1]["method"].get<std::string>().find("baseline kernel"), std::string::npos);
    fs::remove_all(dir);
}
