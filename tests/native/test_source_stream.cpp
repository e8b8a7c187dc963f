// ibl::SummaryStream (issue 28's streaming bake, docs/design-streaming.md):
// the summary and the cleaning of a source fed in bands of rows equal, to
// the bit, the bake's scan() and sanitize() over the whole image.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <vector>

#include "iblbake/ibl/bin_tree.h"
#include "iblbake/ibl/source.h"
#include "iblbake/ibl/specular.h"
#include "reference.h"

using namespace iblbake;

namespace {

// What the bake does today (scan(), sanitize()): summarize the source as it
// is, clean the bad rows, summarize those again.
SourceSummary whole_image(Image& img) {
    SourceSummary s = summarize_source(img);
    clean_bad_rows(img, s.scan);
    refresh_summary_rows(s, img, s.scan.bad_rows);
    return s;
}

// The same rows in bands of `band` (last band first when `backwards`).
SourceSummary in_bands(Image& img, int band, bool backwards) {
    SummaryStream stream(img.width, img.height);
    std::vector<int> starts;
    for (int y = 0; y < img.height; y += band) starts.push_back(y);
    if (backwards) std::reverse(starts.begin(), starts.end());
    for (int y0 : starts) {
        const int n = std::min(band, img.height - y0);
        std::vector<float*> rows(n);
        for (int k = 0; k < n; ++k) rows[k] = img.at(0, y0 + k);
        stream.add_rows(rows.data(), y0, n);
    }
    return stream.finish();
}

template <typename T>
bool same_bits(const T& a, const T& b) {
    return std::memcmp(&a, &b, sizeof(T)) == 0;
}

void expect_equal(const SourceSummary& a, const SourceSummary& b) {
    EXPECT_EQ(a.scan.bad.nan, b.scan.bad.nan);
    EXPECT_EQ(a.scan.bad.inf, b.scan.bad.inf);
    EXPECT_EQ(a.scan.bad.negative, b.scan.bad.negative);
    EXPECT_EQ(a.scan.bad.pixels, b.scan.bad.pixels);
    EXPECT_EQ(a.scan.bad_rows, b.scan.bad_rows);
    EXPECT_TRUE(same_bits(a.scan.max_value, b.scan.max_value));
    ASSERT_EQ(a.hot.mean.size(), b.hot.mean.size());
    for (size_t y = 0; y < a.hot.mean.size(); ++y) {
        EXPECT_TRUE(same_bits(a.hot.mean[y], b.hot.mean[y])) << y;
        EXPECT_TRUE(same_bits(a.hot.power[y], b.hot.power[y])) << y;
        EXPECT_TRUE(same_bits(a.hot.top[y], b.hot.top[y])) << y;
    }
}

Image source_with_bad_values(int w, int h, int seed) {
    Image img = ref::random_smooth_source(w, h, seed);
    img.at(7, 9)[1] = std::numeric_limits<float>::quiet_NaN();
    img.at(w - 1, h - 1)[2] = -2.0f;
    img.at(0, 0)[0] = std::numeric_limits<float>::infinity();
    img.at(5, 9)[0] = -1e-3f;  // a second bad value on a bad row
    img.at(w / 2, h / 2)[0] = 5e4f;  // a hot texel
    return img;
}

}  // namespace

TEST(SummaryStream, BandsEqualTheWholeImageWithBadValues) {
    const Image original = source_with_bad_values(301, 150, 5);
    Image whole = original;
    const SourceSummary expected = whole_image(whole);
    ASSERT_EQ(expected.scan.bad_rows, (std::vector<int>{0, 9, 149}));
    for (int band : {1, 7, 64, 150})
        for (bool backwards : {false, true}) {
            SCOPED_TRACE(testing::Message() << "bands of " << band << (backwards ? ", last first" : ""));
            Image img = original;
            expect_equal(in_bands(img, band, backwards), expected);
            EXPECT_EQ(0, std::memcmp(img.pixels.data(), whole.pixels.data(), img.pixels.size() * sizeof(float)))
                << "cleaned as clean_bad_rows cleans";
        }
}

TEST(SummaryStream, CleanSourcesAndTinyOnes) {
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {3, 2}, {64, 32}, {2048, 1024}}) {
        SCOPED_TRACE(testing::Message() << w << " x " << h);
        const Image original = ref::random_smooth_source(w, h, 11);
        Image whole = original;
        const SourceSummary expected = whole_image(whole);
        EXPECT_TRUE(expected.scan.bad_rows.empty());
        Image img = original;
        expect_equal(in_bands(img, 13, false), expected);
    }
}

// ibl::BinRowStream: the bin tree from bands of rows (a view that can read
// the band's rows alone: any other row is a null pointer) equals
// build_bin_tree on the whole image, every node, chroma bin and kept bin.
namespace {

void expect_same_tree(const BinTree& a, const BinTree& b) {
    ASSERT_EQ(a.levels.size(), b.levels.size());
    for (size_t l = 0; l < a.levels.size(); ++l) {
        ASSERT_EQ(a.levels[l].w, b.levels[l].w);
        ASSERT_EQ(a.levels[l].h, b.levels[l].h);
        const size_t n = size_t(a.levels[l].w) * a.levels[l].h;
        EXPECT_EQ(0, std::memcmp(a.levels[l].nodes.data(), b.levels[l].nodes.data(), n * sizeof(BinNode)))
            << "level " << l;
    }
    ASSERT_EQ(a.chroma.size(), b.chroma.size());
    for (size_t r = 0; r < a.chroma.size(); ++r) {
        ASSERT_EQ(a.chroma[r].size(), b.chroma[r].size()) << r;
        if (!a.chroma[r].empty()) {
            EXPECT_EQ(0, std::memcmp(a.chroma[r].data(), b.chroma[r].data(), a.chroma[r].size() * sizeof(ChromaBin)));
        }
    }
    EXPECT_TRUE(same_bits(a.channel_mean, b.channel_mean));
}

}  // namespace

TEST(BinRowStream, BandsEqualTheWholeImage) {
    Image img = ref::random_smooth_source(301, 150, 7);
    for (int y = 40; y < 60; ++y)  // a coloured patch: bins of varying colour
        for (int x = 100; x < 140; ++x) img.at(x, y)[y % 3] *= 50.0f;
    const double mean[3] = {0.7, 0.9, 1.1};
    BinTreeOptions options;
    options.channel_mean = mean;
    size_t chroma = 0;
    for (int finest : {2, 4, 8, 32, 64}) {
        const int keep_w = finest >= 8 ? finest / 4 : 0;
        std::vector<Bin> keep_whole, keep_bands;
        const BinTree whole = build_bin_tree(img, finest, keep_w ? &keep_whole : nullptr, keep_w, options);
        chroma += whole.chroma_count();
        BinRowStream probe(img.width, img.height, finest);
        const int reach = probe.max_reach();
        // What the streamed bake sizes its bands by before the streams exist:
        // the most rows any bin row's reduction reads (its source_rows).
        for (int h : {1, 2, 3, 7, img.height, 8192}) {
            const BinRowStream s(2 * h, h, finest);
            int most = 1;
            for (int br = 0; br < std::max(2, finest) / 2; ++br) {
                const auto [first, last] = s.source_rows(br);
                if (last >= first) most = std::max(most, last - first + 1);
            }
            EXPECT_EQ(BinRowStream::reach(h, finest), most) << h;
            EXPECT_EQ(s.max_reach(), most) << h;
        }
        for (int band : {reach, reach + 3, 2 * reach + 5, img.height}) {
            SCOPED_TRACE(testing::Message() << "finest " << finest << ", bands of " << band << ", reach " << reach);
            BinRowStream stream(img.width, img.height, finest);
            std::vector<const float*> table(img.height, nullptr);
            const int step = std::max(1, band - reach + 1);
            for (int y0 = 0;; y0 += step) {
                const int y1 = std::min(img.height - 1, y0 + band - 1);
                std::fill(table.begin(), table.end(), nullptr);
                for (int y = y0; y <= y1; ++y) table[y] = img.at(0, y);
                ImageView v(nullptr, img.width, img.height);
                v.rows = table.data();
                stream.add_rows(v, y0, y1);
                if (y1 == img.height - 1) break;
            }
            EXPECT_EQ(stream.pending(), 0);
            keep_bands.clear();
            const BinTree streamed = stream.finish(mean, keep_w ? &keep_bands : nullptr, keep_w, options);
            expect_same_tree(streamed, whole);
            ASSERT_EQ(keep_bands.size(), keep_whole.size());
            if (!keep_whole.empty()) {
                EXPECT_EQ(0, std::memcmp(keep_bands.data(), keep_whole.data(), keep_whole.size() * sizeof(Bin)));
            }
        }
    }
    EXPECT_GT(chroma, 0u) << "no bin of varying colour: the chroma rows went untested";
}

// A stream made without SH9 (the irradiance's own bins beside a tree's)
// gives the same bins, and refuses to give an SH9.
TEST(BinRowStream, WithoutSh9SameBins) {
    const Image img = ref::random_smooth_source(128, 64, 9);
    for (int finest : {2, 16, 64}) {
        BinRowStream with(img.width, img.height, finest), without(img.width, img.height, finest, /*sh9=*/false);
        with.add_rows(img, 0, img.height - 1);
        without.add_rows(img, 0, img.height - 1);
        EXPECT_NO_THROW(with.sh9());
        EXPECT_THROW(without.sh9(), std::logic_error);
        const std::vector<Bin> a = with.take_bins(), b = without.take_bins();
        ASSERT_EQ(a.size(), b.size());
        EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(Bin))) << finest;
    }
}

// ibl::HotStream: the hot split from bands of rows equals split_hot's.
namespace {

void expect_same_split(const HotSplit& a, const HotSplit& b) {
    EXPECT_TRUE(same_bits(a.threshold, b.threshold)) << a.threshold << " " << b.threshold;
    EXPECT_TRUE(same_bits(a.hot_power_fraction, b.hot_power_fraction));
    ASSERT_EQ(a.texels.size(), b.texels.size());
    ASSERT_EQ(a.hot.size(), b.hot.size());
    for (size_t k = 0; k < a.texels.size(); ++k) {
        EXPECT_EQ(a.texels[k].x, b.texels[k].x) << k;
        EXPECT_EQ(a.texels[k].y, b.texels[k].y) << k;
        EXPECT_TRUE(same_bits(a.texels[k].removed, b.texels[k].removed)) << k;
        EXPECT_EQ(0, std::memcmp(&a.hot[k], &b.hot[k], sizeof(RadiancePoint))) << k;
    }
}

// through_summary: the rows reach the stream from SummaryStream::add_rows
// (the streamed bake's one pass over a band), on a copy of the image.
HotSplit hot_in_bands(const Image& img, int band, bool backwards, int max_hot, double rel, const HotRows& rows,
                      bool through_summary = false) {
    HotStream stream(img.width, img.height, max_hot);
    Image copy = img;
    SummaryStream sums(img.width, img.height);
    std::vector<int> starts;
    for (int y = 0; y < img.height; y += band) starts.push_back(y);
    if (backwards) std::reverse(starts.begin(), starts.end());
    for (int y0 : starts) {
        const int n = std::min(band, img.height - y0);
        std::vector<float*> r(n);
        for (int k = 0; k < n; ++k) r[k] = copy.at(0, y0 + k);
        if (through_summary) {
            sums.add_rows(r.data(), y0, n, &stream);
        } else {
            stream.add_rows(r.data(), y0, n);
        }
    }
    if (through_summary) {
        const SourceSummary s = sums.finish();
        EXPECT_EQ(s.hot.mean, rows.mean);  // the summary of the same clean rows
    }
    return stream.finish(rel, rows);
}

}  // namespace

TEST(HotStream, BandsEqualSplitHot) {
    struct World {
        const char* what;
        int hot;     // texels made bright
        bool ties;   // every bright texel the same value
        bool minus_zero = false;  // -0 beside each (a clean value whose sign bit is set, in its block of texels)
    };
    for (const World& world : {World{"no hot texel", 0, false}, World{"ten", 10, false},
                               World{"1500 (more than max_hot)", 1500, false}, World{"50000", 50000, false},
                               World{"2000 equal ones", 2000, true}, World{"1500 beside -0", 1500, false, true}}) {
        Image img = ref::random_smooth_source(400, 200, 3);
        unsigned state = 12345;
        for (int k = 0; k < world.hot; ++k) {
            state = state * 1664525u + 1013904223u;
            const int x = int(state >> 8) % img.width, y = int(state >> 20) % img.height;
            img.at(x, y)[k % 3] = world.ties ? 1e4f : 1e3f + float(k % 977);
            if (world.minus_zero) img.at(x ^ 1, y)[(k + 1) % 3] = -0.0f;
        }
        const SourceSummary summary = summarize_source(img);
        for (int max_hot : {0, 1, 64, 1024, 100000})
            for (double rel : {16.0, 0.5}) {
                SCOPED_TRACE(testing::Message() << world.what << ", max_hot " << max_hot << ", rel " << rel);
                const HotSplit expected = split_hot(img, rel, max_hot, &summary.hot);
                EXPECT_LE(expected.hot.size(), size_t(std::max(0, max_hot)));
                if (world.hot == 1500 && max_hot == 1024) {
                    EXPECT_GT(expected.hot.size(), 500u) << "max_hot decides";
                }
                if (world.hot == 10 && max_hot >= 64) {
                    EXPECT_GE(expected.hot.size(), 10u) << "the relative threshold decides";
                }
                for (int band : {1, 7, 200})
                    for (bool backwards : {false, true})
                        for (bool through_summary : {false, true})
                            expect_same_split(
                                hot_in_bands(img, band, backwards, max_hot, rel, summary.hot, through_summary),
                                expected);
            }
    }
}

// ibl::MirrorStream: mip 0 (r = 0 lookups) from bands of rows equals
// specular_mirror on the whole image.
TEST(MirrorStream, BandsEqualSpecularMirror) {
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {3, 2}, {301, 150}, {1024, 512}})
        for (int n : {1, 7, 64, 256}) {
            const Image img = ref::random_smooth_source(w, h, 17);
            Cubemap expected(n);
            specular_mirror(expected, img);
            for (int band : {2, 5, 64, h + 1}) {
                if (band > h + 1) continue;
                SCOPED_TRACE(testing::Message() << w << " x " << h << ", n " << n << ", bands of " << band);
                Cubemap streamed(n);
                std::fill(streamed.pixels.begin(), streamed.pixels.end(), -1.0f);
                MirrorStream stream(streamed, w, h);
                std::vector<const float*> table(h, nullptr);
                for (int y0 = 0;; y0 += std::max(1, band - 1)) {  // bands overlapping by one row
                    const int y1 = std::min(h - 1, y0 + band - 1);
                    std::fill(table.begin(), table.end(), nullptr);
                    for (int y = y0; y <= y1; ++y) table[y] = img.at(0, y);
                    ImageView v(nullptr, w, h);
                    v.rows = table.data();
                    stream.add_rows(v, y0, y1);
                    if (y1 == h - 1) break;
                }
                EXPECT_EQ(stream.pending(), 0u);
                EXPECT_EQ(0, std::memcmp(streamed.pixels.data(), expected.pixels.data(),
                                         expected.pixels.size() * sizeof(float)));
            }
        }
}
