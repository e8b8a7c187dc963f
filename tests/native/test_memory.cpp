// What a bake lets go of early (issue 25: the per-channel moments' memory
// paid back): the source's rows once the bin tree is done with them, and
// each output's pixels once a sink that takes them has written the file.
// Each release must leave every result exactly as it was.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <vector>

#include <tbb/task_arena.h>

#include "iblbake/bake/bake.h"
#include "iblbake/export/preset.h"
#include "iblbake/ibl/bin_tree.h"
#include "iblbake/image/image.h"
#include "iblbake/pipeline/write.h"
#include "iblbake/util/parallel.h"
#include "scratch.h"

using namespace iblbake;

namespace {

// A world whose colour and brightness change everywhere (bins of varying
// colour at every level), with a small bright red sun.
Image coloured_world(int w, int h) {
    Image img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float* p = img.at(x, y);
            p[0] = 0.2f + 0.15f * std::sin(0.37f * x + 0.11f * y);
            p[1] = 0.3f + 0.2f * std::cos(0.05f * x * y / (w + 1.0f) + 0.3f * y);
            p[2] = 0.5f + 0.4f * std::sin(0.021f * x - 0.17f * y);
            if (std::abs(x - w / 3) < 2 && std::abs(y - h / 4) < 2) p[0] = 5000.0f, p[1] = 400.0f, p[2] = 0.0f;
        }
    return img;
}

bool same_trees(const BinTree& a, const BinTree& b) {
    if (a.levels.size() != b.levels.size() || a.chroma.size() != b.chroma.size()) return false;
    for (size_t l = 0; l < a.levels.size(); ++l) {
        const BinLevel &la = a.levels[l], &lb = b.levels[l];
        if (la.w != lb.w || la.h != lb.h || la.nodes.size() != lb.nodes.size()) return false;
        if (std::memcmp(la.nodes.data(), lb.nodes.data(), la.nodes.size() * sizeof(BinNode)) != 0) return false;
    }
    for (size_t r = 0; r < a.chroma.size(); ++r) {
        if (a.chroma[r].size() != b.chroma[r].size()) return false;
        if (!a.chroma[r].empty() &&
            std::memcmp(a.chroma[r].data(), b.chroma[r].data(), a.chroma[r].size() * sizeof(ChromaBin)) != 0)
            return false;
    }
    return true;
}

}  // namespace

TEST(Parallel, OrderedForRunsEachIndexOnceAndReportsEveryFinishedPrefix) {
    for (const int n : {1, 2, 7, 300}) {
        std::vector<std::atomic<int>> runs(size_t(n) + 3);
        std::vector<int> frontiers;
        std::atomic<bool> early{false};  // a frontier past an unfinished index
        parallel_for_ordered(
            3, n + 3, [&](int i) { runs[size_t(i)].fetch_add(1); },
            [&](int k) {
                for (int i = 3; i < k; ++i) early = early || runs[size_t(i)].load() != 1;
                frontiers.push_back(k);
            });
        for (int i = 3; i < n + 3; ++i) EXPECT_EQ(runs[size_t(i)].load(), 1) << i;
        EXPECT_FALSE(early.load());
        ASSERT_FALSE(frontiers.empty());
        EXPECT_EQ(frontiers.back(), n + 3);
        for (size_t k = 1; k < frontiers.size(); ++k) EXPECT_LT(frontiers[k - 1], frontiers[k]);
    }
    bool called = false;
    parallel_for_ordered(5, 5, [&](int) { called = true; }, [&](int) { called = true; });
    EXPECT_FALSE(called);
}

TEST(RowRelease, RowsAboveGoBackAsZerosTheRestStay) {
    Image img(1000, 300);  // 12 000 bytes a row: rows straddle pages
    for (size_t k = 0; k < img.pixels.size(); ++k) img.pixels[k] = 1.0f + float(k % 97);
    const Image before = img;
    RowRelease release(img);
    release.before(100);
    const size_t first = release.released();
    EXPECT_GT(first, size_t(100 - 2) * 12000 - 8192);  // all but the partial pages at both ends
    EXPECT_LE(first, size_t(100) * 12000);
    release.before(50);  // never backwards
    EXPECT_EQ(release.released(), first);
    // Rows from 100 on are untouched; rows above read as their values or as
    // zeros (whole pages gone), never anything else.
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            for (int c = 0; c < 3; ++c) {
                const float v = img.at(x, y)[c], was = before.at(x, y)[c];
                if (y >= 100) ASSERT_EQ(v, was) << x << ", " << y;
                else ASSERT_TRUE(v == was || v == 0.0f) << x << ", " << y;
            }
    EXPECT_EQ(img.at(0, 50)[0], 0.0f);  // a row well inside the pages given back
    release.before(img.height);
    EXPECT_GT(release.released(), size_t(img.height - 1) * 12000 - 8192);
}

TEST(BinTree, SourceRowsReportedDoneAreNeverReadAgain) {
    // Every row reported done is overwritten with NaN at once: the tree
    // must be the one built from the clean source, bit for bit.
    for (const int finest : {4, 16, 64}) {
        const Image clean = coloured_world(256, 128);
        BinTreeOptions plain;
        const BinTree expected = build_bin_tree(clean, finest, nullptr, 0, plain);
        Image poisoned = clean;
        std::vector<int> calls;
        BinTreeOptions o;
        o.source_done = [&](int y) {
            const int from = calls.empty() ? 0 : calls.back();
            for (int r = from; r < y; ++r)
                for (int x = 0; x < poisoned.width; ++x)
                    for (int c = 0; c < 3; ++c) poisoned.at(x, r)[c] = std::numeric_limits<float>::quiet_NaN();
            calls.push_back(std::max(from, y));
        };
        for (const int threads : {0, 1}) {  // every core; one (each row reported as it is done)
            poisoned = clean;
            calls.clear();
            const BinTree got = threads == 0 ? build_bin_tree(poisoned, finest, nullptr, 0, o)
                                             : tbb::task_arena(threads).execute([&] {
                                                   return build_bin_tree(poisoned, finest, nullptr, 0, o);
                                               });
            EXPECT_TRUE(same_trees(expected, got)) << "finest " << finest << ", threads " << threads;
            ASSERT_FALSE(calls.empty());
            EXPECT_EQ(calls.back(), clean.height);
            if (threads == 1 && finest >= 16) {
                EXPECT_GT(calls.size(), size_t(2)) << "rows go back as the build goes, not at its end";
            }
        }
        EXPECT_GT(expected.chroma_count(), size_t(0));  // the per-channel moments were exercised
    }
}

namespace {

// A sink that takes the cubes (as the CLI's writer does with no preview
// and no preset) and keeps a copy of what it was given.
class TakingSink final : public OutputSink {
public:
    void cube(const std::string& stem, const Cubemap&) override { by_reference.push_back(stem); }
    bool takes_cubes() const override { return true; }
    void take_cube(const std::string& stem, Cubemap&& cube) override {
        const std::lock_guard<std::mutex> lock(m);
        taken[stem] = std::move(cube);
    }
    void lut(const Image&, const std::string&) override {}
    void wait() override {}
    std::mutex m;
    std::map<std::string, Cubemap> taken;
    std::vector<std::string> by_reference;
};

}  // namespace

TEST(Bake, SinkThatTakesCubesGetsTheSamePixelsAndTheResultKeepsTheirSizes) {
    BakeOptions o;
    o.face_size = 32;
    o.irradiance_size = 8;
    o.lut_size = 16;
    const Image world = coloured_world(128, 64);
    const BakeResult plain = compute_bake(world, o);
    TakingSink sink;
    const BakeResult r = compute_bake(world, o, {}, nullptr, &sink);  // an owned copy: its rows go back too
    EXPECT_TRUE(sink.by_reference.empty());
    ASSERT_EQ(r.specular.size(), plain.specular.size());
    ASSERT_EQ(sink.taken.size(), plain.specular.size() + 1);
    for (size_t i = 0; i < r.specular.size(); ++i) {
        const std::string stem = "specular_" + std::to_string(r.specular_levels[i]);
        EXPECT_EQ(r.specular[i].size, plain.specular[i].size);
        EXPECT_TRUE(r.specular[i].pixels.empty()) << stem;
        ASSERT_EQ(sink.taken.count(stem), size_t(1)) << stem;
        EXPECT_EQ(sink.taken[stem].size, plain.specular[i].size);
        EXPECT_TRUE(sink.taken[stem].pixels == plain.specular[i].pixels) << stem;
    }
    ASSERT_TRUE(r.irradiance && plain.irradiance);
    EXPECT_TRUE(r.irradiance->pixels.empty());
    EXPECT_EQ(r.irradiance->size, plain.irradiance->size);
    EXPECT_TRUE(sink.taken["irradiance"].pixels == plain.irradiance->pixels);
    ASSERT_TRUE(r.lut && plain.lut);
    EXPECT_TRUE(r.lut->pixels == plain.lut->pixels);  // the LUT stays in the result
}

TEST(Bake, SourceGivenBackDuringTheTreeChangesNoOutput) {
    // A bake that owns its source (compute_bake) gives its rows back as the
    // tree is built, unless something reads them later: the irradiance's own
    // bins (finer than the tree's can serve), an export that keeps the
    // source. Every output must equal the bake of the same pixels read in
    // place (compute_bake_view, which never gives anything back).
    const Image world = coloured_world(256, 128);
    auto same = [](const BakeResult& a, const BakeResult& b) {
        bool ok = a.specular.size() == b.specular.size() && bool(a.irradiance) == bool(b.irradiance);
        for (size_t i = 0; ok && i < a.specular.size(); ++i) ok = a.specular[i].pixels == b.specular[i].pixels;
        if (ok && a.irradiance) ok = a.irradiance->pixels == b.irradiance->pixels;
        if (ok && a.extra_irradiance) ok = b.extra_irradiance && a.extra_irradiance->pixels == b.extra_irradiance->pixels;
        return ok && a.sh9 == b.sh9;
    };
    for (int variant = 0; variant < 4; ++variant) {
        BakeOptions o;
        o.face_size = 32;
        o.irradiance_size = 8;
        o.lut = false;
        o.irradiance_bins = 4;  // the tree's bins serve the irradiance: nothing reads the source after the tree
        if (variant == 1) o.irradiance_bins = 128;  // its own pass over the source, after the tree
        if (variant == 2) o.extra.keep_source = true;
        if (variant == 3) o.rotation = 30.0;  // the turned copy is the one owned
        const BakeResult owned = compute_bake(world, o);
        const BakeResult in_place = compute_bake_view(world, o);
        EXPECT_TRUE(same(owned, in_place)) << "variant " << variant;
        if (variant == 2) {
            ASSERT_TRUE(owned.source.has_value());
            EXPECT_TRUE(owned.source->pixels == world.pixels);
        }
    }
}

TEST(Bake, WriterTakesCubesOnlyWhenNothingAfterReadsThem) {
    const std::filesystem::path dir = scratch::root() / "taking";
    BakeOptions o;
    o.face_size = 64;
    WriteOptions files_only;
    const BakePlan a = make_plan(o, files_only);
    EXPECT_TRUE(BakeWriter(dir / "a", a).takes_cubes());
    WriteOptions with_preview;
    with_preview.preview = true;
    const BakePlan b = make_plan(o, with_preview);
    EXPECT_FALSE(BakeWriter(dir / "b", b).takes_cubes());
    WriteOptions with_preset;
    with_preset.presets = parse_presets({"three"});
    const BakePlan c = make_plan(o, with_preset);
    EXPECT_FALSE(BakeWriter(dir / "c", c).takes_cubes());
    std::filesystem::remove_all(dir);
}
