// Source cleaning, the hot/rest split, vector reduction and SH projection.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <algorithm>
#include <limits>
#include <tuple>
#include <utility>
#include <vector>

#include "iblbake/ibl/bin_tree.h"
#include "iblbake/ibl/source.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/latlong.h"
#include "reference.h"

using namespace iblbake;

namespace {
// The bins' column sums are made in float (source.cpp's add_row_pieces):
// each latitude weight is rounded to float once (2^-24 relative) and each
// column's few dozen products summed in float, so a bin, and whatever is
// summed from bins, is its exact integral to a few units of 2^-24 of the
// magnitudes summed (measured: at most 4e-8 of the total here). The tests
// of exactness allow 16 such units, 2^-20 (1e-6) of the magnitude: far
// below any error of the integrals themselves (a wrong hat or a missing
// piece is 1e-3 or more).
constexpr double kFloatSums = 0x1p-20;
}  // namespace

// The one-pass summary gives exactly what the three passes give, bad
// texels and all (it describes the source as it is).
TEST(Source, SummaryEqualsTheThreePasses) {
    Image img = ref::random_smooth_source(301, 150, 3);
    img.at(7, 9)[1] = std::numeric_limits<float>::quiet_NaN();
    img.at(300, 149)[2] = -2.0f;
    img.at(0, 0)[0] = std::numeric_limits<float>::infinity();
    img.at(150, 75)[0] = 5e4f;  // a hot texel
    const SourceSummary s = summarize_source(img);
    const SourceScan scan = scan_source(img);
    EXPECT_EQ(s.scan.bad.nan, 1u);
    EXPECT_EQ(s.scan.bad.inf, 1u);
    EXPECT_EQ(s.scan.bad.negative, 1u);
    EXPECT_EQ(s.scan.bad.pixels, scan.bad.pixels);
    EXPECT_EQ(s.scan.bad_rows, scan.bad_rows);
    EXPECT_EQ(s.scan.max_value, scan.max_value);
    const HotRows h = hot_rows(img);
    for (int y = 0; y < img.height; ++y) {
        EXPECT_EQ(std::memcmp(&s.hot.mean[y], &h.mean[y], sizeof(double)), 0) << y;  // NaN rows too
        EXPECT_EQ(std::memcmp(&s.hot.power[y], &h.power[y], sizeof(double)), 0) << y;
        EXPECT_EQ(std::memcmp(&s.hot.top[y], &h.top[y], sizeof(float)), 0) << y;
    }
    // On the cleaned source: the split from the summary equals the
    // standalone one bit for bit.
    sanitize(img);
    const SourceSummary c = summarize_source(img);
    const HotSplit a = split_hot(img, 16.0, 64), b = split_hot(img, 16.0, 64, &c.hot);
    EXPECT_GT(a.hot.size(), 0u);
    ASSERT_EQ(a.texels.size(), b.texels.size());
    EXPECT_EQ(a.threshold, b.threshold);
    for (size_t k = 0; k < a.texels.size(); ++k) {
        EXPECT_EQ(a.texels[k].x, b.texels[k].x);
        EXPECT_EQ(a.texels[k].y, b.texels[k].y);
        for (int ch = 0; ch < 3; ++ch) EXPECT_EQ(a.hot[k].power[ch], b.hot[k].power[ch]);
    }
}

// A bad source's summary, its bad rows redone after cleaning, equals the
// standalone passes over the cleaned source bit for bit (the bake then skips
// two whole passes).
TEST(Source, SummaryRefreshedAfterCleaningEqualsTheCleanPasses) {
    Image img = ref::random_smooth_source(301, 150, 5);
    img.at(7, 9)[1] = std::numeric_limits<float>::quiet_NaN();
    img.at(300, 149)[2] = -2.0f;
    img.at(0, 0)[0] = std::numeric_limits<float>::infinity();
    img.at(5, 9)[0] = -1e-3f;  // a second bad value on a bad row
    img.at(150, 75)[0] = 5e4f;  // a hot texel
    img.at(151, 76)[1] = 2e4f;
    SourceSummary s = summarize_source(img);
    ASSERT_EQ(s.scan.bad_rows, (std::vector<int>{0, 9, 149}));
    clean_bad_rows(img, s.scan);
    refresh_summary_rows(s, img, s.scan.bad_rows);
    const HotRows h = hot_rows(img);
    for (int y = 0; y < img.height; ++y) {
        EXPECT_EQ(s.hot.mean[y], h.mean[y]) << y;
        EXPECT_EQ(s.hot.power[y], h.power[y]) << y;
        EXPECT_EQ(s.hot.top[y], h.top[y]) << y;
    }
    // The same through a view whose bad rows are cleaned copies.
    Image dirty = ref::random_smooth_source(301, 150, 5);
    dirty.at(20, 33)[2] = std::numeric_limits<float>::quiet_NaN();
    SourceSummary d = summarize_source(dirty);
    std::vector<float> store;
    std::vector<const float*> table;
    const ImageView v = sanitized_view(dirty, d.scan, store, table);
    refresh_summary_rows(d, v, d.scan.bad_rows);
    Image copy = dirty;
    sanitize(copy);
    const HotRows hc = hot_rows(copy);
    for (int y = 0; y < copy.height; ++y) {
        EXPECT_EQ(d.hot.mean[y], hc.mean[y]) << y;
        EXPECT_EQ(d.hot.power[y], hc.power[y]) << y;
        EXPECT_EQ(d.hot.top[y], hc.top[y]) << y;
    }
}

// Zeros and the finiteness and range checks, across the parallel blocks.
TEST(Source, BufferChecksFindOneBadValueAnywhere) {
    const size_t n = (size_t(1) << 18) * 5 + 17;  // several blocks of each helper, and a tail
    Image img(int(n / 3), 1);
    for (float v : img.pixels) ASSERT_EQ(v, 0.0f);
    Cubemap c(64);
    for (float v : c.pixels) ASSERT_EQ(v, 0.0f);
    EXPECT_TRUE(all_finite(img.pixels));
    EXPECT_FALSE(any_beyond(img.pixels, 65504.0f));
    for (size_t at : {size_t(0), n / 2, img.pixels.size() - 1}) {
        img.pixels[at] = std::numeric_limits<float>::quiet_NaN();
        EXPECT_FALSE(all_finite(img.pixels)) << at;
        EXPECT_TRUE(any_beyond(img.pixels, 65504.0f)) << at;
        img.pixels[at] = -std::numeric_limits<float>::infinity();
        EXPECT_FALSE(all_finite(img.pixels)) << at;
        img.pixels[at] = -65505.0f;
        EXPECT_TRUE(all_finite(img.pixels)) << at;
        EXPECT_TRUE(any_beyond(img.pixels, 65504.0f)) << at;
        img.pixels[at] = 65504.0f;
        EXPECT_FALSE(any_beyond(img.pixels, 65504.0f)) << at;
        img.pixels[at] = 0.0f;
    }
    // One block (no tasks), the edges of the ranges, NaN with its sign bit set.
    std::vector<float> small = {1.0f, -0.0f, std::numeric_limits<float>::max(), -std::numeric_limits<float>::max()};
    EXPECT_TRUE(all_finite(small));
    EXPECT_TRUE(any_beyond(small, 65504.0f));
    EXPECT_FALSE(any_beyond(small, std::numeric_limits<float>::max()));
    EXPECT_FALSE(any_beyond(small, std::numeric_limits<float>::infinity()));
    small.push_back(-std::numeric_limits<float>::quiet_NaN());
    EXPECT_FALSE(all_finite(small));
    EXPECT_TRUE(any_beyond(small, std::numeric_limits<float>::infinity()));
    EXPECT_TRUE(any_beyond(std::vector<float>{0.0f}, -1.0f));
    EXPECT_FALSE(any_beyond(std::vector<float>{}, -1.0f));
    EXPECT_TRUE(all_finite(std::vector<float>{}));
}

// The scan of rows with bad values goes block by block (16 pixels), the
// vectorised max alone where a block is clean: the counts, the bad rows and
// the largest good value are a value-by-value classification's, wherever
// in a row (and its blocks) the bad values and the largest value lie.
TEST(Source, ScanMatchesAValueByValueCount) {
    const int w = 1000, h = 6;  // 62 whole blocks and a partial one per row
    Image img = ref::random_smooth_source(w, h, 11);
    const float bad[] = {std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::quiet_NaN(),
                         std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(), -1e-30f,
                         -3.0f, -0.0f};
    uint32_t seed = 7;
    auto next = [&] { return seed = seed * 1664525u + 1013904223u; };
    for (int k = 0; k < 40; ++k) {
        const int y = 1 + int(next() % (h - 1));  // row 0 stays clean
        img.at(int(next() % w), y)[next() % 3] = bad[next() % std::size(bad)];
    }
    img.at(w - 1, 3)[2] = 7e5f;  // the largest good value, in the last partial block of a bad row
    img.at(w / 2, 4)[0] = -0.0f;
    BadInputCounts want;
    float want_max = 0.0f;
    std::vector<int> want_rows;
    for (int y = 0; y < h; ++y) {
        bool row_bad = false;
        for (int x = 0; x < w; ++x) {
            bool px_bad = false;
            for (int c = 0; c < 3; ++c) {
                const float v = img.at(x, y)[c];
                if (std::isnan(v)) ++want.nan, px_bad = true;
                else if (std::isinf(v)) ++want.inf, px_bad = true;
                else if (v < 0.0f) ++want.negative, px_bad = true;
                else want_max = std::max(want_max, v);
            }
            want.pixels += px_bad;
            row_bad |= px_bad;
        }
        if (row_bad) want_rows.push_back(y);
    }
    const SourceScan s = scan_source(img);
    EXPECT_EQ(s.bad.nan, want.nan);
    EXPECT_EQ(s.bad.inf, want.inf);
    EXPECT_EQ(s.bad.negative, want.negative);
    EXPECT_EQ(s.bad.pixels, want.pixels);
    EXPECT_GT(want.pixels, 30u);
    EXPECT_EQ(s.max_value, 7e5f);
    EXPECT_EQ(s.max_value, want_max);
    EXPECT_EQ(s.bad_rows, want_rows);
}

TEST(Source, SanitizeCountsAndZeroes) {
    Image img = ref::constant_source(4, 2, 1.0f);
    img.at(0, 0)[0] = std::numeric_limits<float>::quiet_NaN();
    img.at(0, 0)[1] = -1.0f;
    img.at(1, 0)[2] = std::numeric_limits<float>::infinity();
    img.at(2, 1)[0] = -std::numeric_limits<float>::infinity();
    img.at(3, 1)[1] = -1e-30f;
    const BadInputCounts c = sanitize(img);
    EXPECT_EQ(c.nan, 1u);
    EXPECT_EQ(c.inf, 2u);
    EXPECT_EQ(c.negative, 2u);
    EXPECT_EQ(c.pixels, 4u);
    for (float v : img.pixels) EXPECT_TRUE(std::isfinite(v) && v >= 0.0f);
    EXPECT_EQ(img.at(0, 0)[2], 1.0f);  // good channels of a bad pixel are kept
}

TEST(Source, HotSplitConservesEnergyAndBoundsRest) {
    // Energy through SPEC's bilinear L: the hot points carry their texels' hats.
    Image img = ref::sun_source(256, 128, {0.3, 0.2, 0.5}, 2.0, 5e4f, 0.5f);
    const auto before = ref::mean_radiance(ref::texel_table(img));
    const HotSplit s = split_hot(img, 16.0, 1024);
    ASSERT_GT(s.hot.size(), 0u);
    EXPECT_LE(s.hot.size(), 1024u);
    const Image rest = rest_image(img, s);
    for (float v : rest.pixels) EXPECT_LE(v, s.threshold * (1 + 1e-6));
    auto after = ref::mean_radiance(ref::texel_table(rest));
    for (const RadiancePoint& p : s.hot)
        for (int c = 0; c < 3; ++c) after[c] += p.power[c] / (4 * kPi);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(after[c] / before[c], 1.0, 1e-5);
    EXPECT_GT(s.hot_power_fraction, 0.5);
}

TEST(Source, HotSplitRespectsCap) {
    Image img = ref::sun_source(256, 128, {0, 0, 1}, 10.0, 1e3f, 0.1f);
    const HotSplit s = split_hot(img, 4.0, 50);
    EXPECT_LE(s.hot.size(), 50u);
    const HotSplit none = split_hot(img, 4.0, 0);
    EXPECT_EQ(none.hot.size(), 0u);
    EXPECT_EQ(rest_image(img, none).pixels, img.pixels);
}

TEST(Source, RestBinsWithoutTheRestImage) {
    // Any sizes, dividing or not: the hot texels' gifts come out of every bin they overlap.
    for (const auto& [w, h, bw] : {std::tuple{256, 128, 16}, std::tuple{300, 150, 32}, std::tuple{97, 41, 8}}) {
        const Image img = ref::sun_source(w, h, {0.3, 0.2, 0.5}, 4.0, 5e4f, 0.5f);
        const HotSplit s = split_hot(img, 16.0, 64);
        ASSERT_GT(s.texels.size(), 0u);
        const std::vector<Bin> direct = reduce_to_bins(rest_image(img, s), bw, bw / 2);
        const std::vector<Bin> fast = reduce_rest_to_bins(img, s, bw, bw / 2);
        // The hot texels come out in double from bins summed in float with
        // them: a rest bin keeps float's rounding of the whole bin, sun
        // included (kFloatSums of the bin before the removal).
        const std::vector<Bin> whole = reduce_to_bins(img, bw, bw / 2);
        ASSERT_EQ(direct.size(), fast.size());
        for (size_t b = 0; b < direct.size(); ++b)
            for (int c = 0; c < 3; ++c) {
                const double scale = kFloatSums * (1e-3 + whole[b].power[c]);
                EXPECT_GE(fast[b].power[c], 0.0) << w << " bin " << b;
                EXPECT_NEAR(fast[b].power[c], direct[b].power[c], scale) << w << " bin " << b;
                for (int k = 0; k < 3; ++k) EXPECT_NEAR(fast[b].vector[c][k], direct[b].vector[c][k], scale);
            }
    }
}

TEST(Source, BinReductionIsExactForAnySourceSize) {
    // Constant radiance 1: total power 4 pi, total vector 0, and the bins of
    // the upper hemisphere (the equator is a bin edge) carry integral of
    // max(0, w.up) = pi exactly, whatever the source size.
    for (auto [w, h] : {std::pair{1, 1}, {2, 1}, {3, 7}, {96, 48}, {1000, 333}}) {
        const Image img = ref::constant_source(w, h, 1.0f);
        const std::vector<Bin> bins = reduce_to_bins(img, 16, 8);
        double power = 0, up = 0, vx = 0;
        for (int by = 0; by < 8; ++by)
            for (int bx = 0; bx < 16; ++bx) {
                const Bin& b = bins[size_t(by) * 16 + bx];
                power += b.power[0];
                vx += b.vector[0][0];
                if (by < 4) up += b.vector[0][1];  // engine y = Blender z (up)
            }
        EXPECT_NEAR(power, 4 * kPi, kFloatSums * 4 * kPi) << w << "x" << h;
        EXPECT_NEAR(vx, 0.0, kFloatSums * 4 * kPi);
        EXPECT_NEAR(up, kPi, kFloatSums * kPi) << w << "x" << h;
        // Coarsening is exact too.
        const std::vector<Bin> coarse = coarsen_bins(bins, 16, 8);
        double up2 = 0;
        for (int by = 0; by < 2; ++by)
            for (int bx = 0; bx < 8; ++bx) up2 += coarse[size_t(by) * 8 + bx].vector[0][1];
        EXPECT_NEAR(up2, kPi, kFloatSums * kPi);
    }
}

TEST(Source, BinReductionGivesTheSameBitsInAnyColumnChunks) {
    // BinReduction::row reduces a bin row a chunk of columns at a time. A
    // source of two whole default chunks and a part that is not a multiple
    // of 8 columns (the SH9 kernel's lanes), with a different value in every
    // texel and channel: every chunk width gives the bins and SH9 of one
    // chunk as wide as the row (the reduction before chunks).
    const int w = 2605, h = 41, bw = 16;
    Image img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                img.at(x, y)[c] = float(1.0 + 0.5 * std::sin(0.013 * x + c) + 0.3 * std::cos(0.37 * y) +
                                        0.1 * ((x * 7919 + y * 104729 + c * 31) % 97) / 97.0);
    auto reduce = [&](int chunk, std::vector<Bin>& bins, std::array<Sh9, 3>& sh9) {
        const BinReduction red(img, bw, bw / 2, /*sh9=*/true, chunk);
        bins.assign(size_t(bw) * (bw / 2), Bin{});
        std::vector<std::array<Sh9, 3>> rows(size_t(bw / 2));
        for (int br = 0; br < bw / 2; ++br) red.row(br, &bins[size_t(br) * bw], &rows[size_t(br)]);
        sh9 = sum_sh9_rows(rows);
    };
    std::vector<Bin> whole_bins;
    std::array<Sh9, 3> whole_sh9{};
    reduce(2608, whole_bins, whole_sh9);  // one chunk
    double power = 0.0;
    for (const Bin& b : whole_bins) power += b.power[1];
    EXPECT_GT(power, 4.0 * kPi);  // the values are above 1 almost everywhere: not an empty reduction
    for (int chunk : {16, 48, 1024, BinReduction::kChunkColumns, 4096}) {
        std::vector<Bin> bins;
        std::array<Sh9, 3> sh9{};
        reduce(chunk, bins, sh9);
        ASSERT_EQ(bins.size(), whole_bins.size());
        EXPECT_EQ(std::memcmp(bins.data(), whole_bins.data(), bins.size() * sizeof(Bin)), 0) << chunk;
        EXPECT_EQ(std::memcmp(sh9.data(), whole_sh9.data(), sizeof(sh9)), 0) << chunk;
    }
    EXPECT_THROW(BinReduction(img, bw, bw / 2, false, 24), std::invalid_argument);
    EXPECT_THROW(BinReduction(img, bw, bw / 2, false, 0), std::invalid_argument);
}

TEST(Source, TexelIntegralsMatchQuadrature) {
    // The closed forms against a dense midpoint rule in (phi, s) on one rectangle.
    const double u0 = 0.13, u1 = 0.31, v0 = 0.55, v1 = 0.97;
    const LonIntegrals lon = lon_integrals(u0, u1);
    const LatIntegrals lat = lat_integrals(v0, v1);
    const int n = 2000;
    Vec3d m{0, 0, 0};
    double om = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double u = u0 + (u1 - u0) * (i + 0.5) / n;
            const double s0 = std::sin((v0 - 0.5) * kPi), s1 = std::sin((v1 - 0.5) * kPi);
            const double s = s0 + (s1 - s0) * (j + 0.5) / n;
            const double d_om = (u1 - u0) * 2 * kPi / n * (s1 - s0) / n;
            const double c = std::sqrt(1 - s * s), phi = (0.5 - u) * 2 * kPi;
            const Vec3d w = blender_to_engine(Vec3d{c * std::cos(phi), c * std::sin(phi), s});
            m += w * d_om;
            om += d_om;
        }
    const Vec3d exact = rect_moment(lon, lat);
    EXPECT_NEAR(rect_solid_angle(lon, lat), om, 1e-9);
    EXPECT_NEAR(exact.x, m.x, 1e-7);
    EXPECT_NEAR(exact.y, m.y, 1e-7);
    EXPECT_NEAR(exact.z, m.z, 1e-7);
}

TEST(Source, OverlayPartitions) {
    const auto p = overlay_partitions(3, 2);  // edges 1/3, 1/2, 2/3
    ASSERT_EQ(p.size(), 4u);
    EXPECT_EQ(p[1].a, 1);
    EXPECT_EQ(p[1].b, 0);
    EXPECT_DOUBLE_EQ(p[1].t1, 0.5);
    EXPECT_EQ(overlay_partitions(4, 2).size(), 4u);  // nested edges: no slivers
}

TEST(Source, ShOfConstantIsDcOnly) {
    const Image img = ref::constant_source(64, 32, 1.0f);
    const auto sh = project_sh9_bilinear(img, 16);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(sh[c][0], 0.282095 * 4 * kPi, 1e-6);
        for (int i = 1; i < 9; ++i) EXPECT_NEAR(sh[c][i], 0.0, kFloatSums * sh[c][0]) << i;
    }
}

TEST(Source, ShOfDirectionalLightMatchesBasis) {
    // A single bright texel at Blender -Y (engine +Z): L_lm = P * Y_lm(+Z) to
    // second order in the texel size.
    Image img(256, 128);
    const int x = int(0.75 * 256), y = 64;  // u = 0.75 is -Y, equator
    img.at(x, y)[0] = 1.0f;
    const auto sh = project_sh9_bilinear(img, 16);
    const Vec3d d = blender_to_engine(latlong_texel_direction(x, y, 256, 128));
    const Sh9 basis = sh9_basis(d);
    const double om = latlong_row_solid_angle(y, 256, 128);
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(sh[0][i], basis[i] * om, 1e-3 * om);
    EXPECT_GT(d.z, 0.99);
}

TEST(Source, BilinearIsExactAtTexelCentresAndWraps) {
    Image img(4, 2);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 4; ++x) img.at(x, y)[0] = float(y * 4 + x);
    float v[3];
    latlong_bilinear(img, blender_to_engine(latlong_texel_direction(2, 1, 4, 2)), v);
    EXPECT_NEAR(v[0], 6.0f, 1e-5);
    // u = 0 (the seam) halfway between column 3 and column 0.
    latlong_bilinear(img, blender_to_engine(latlong_to_direction(0.0, 1.0 - 0.25)), v);
    EXPECT_NEAR(v[0], 0.5f * (3 + 0), 1e-5);
}

TEST(Source, RemapIsIdentityOrAColumnShiftForRotationsAboutZ) {
    const Image src = ref::random_smooth_source(64, 32, 3);
    const Image same = remap_latlong(src, {1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0});
    for (size_t k = 0; k < src.pixels.size(); ++k) ASSERT_NEAR(same.pixels[k], src.pixels[k], 1e-5f);
    // Looking up Rz(90 deg) d: the result at column x is the source at x - W/4
    // (u = 0.5 - phi / 2 pi falls by 1/4 as phi grows by 90 degrees).
    const Image rot = remap_latlong(src, {0, -1, 0, 1, 0, 0, 0, 0, 1}, {0, 0, 0});
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x)
            for (int k = 0; k < 3; ++k) ASSERT_NEAR(rot.at(x, y)[k], src.at((x + 64 - 16) % 64, y)[k], 1e-5f);
    // A uniform scale changes nothing (the lookup is normalised); a zero map
    // reads the image centre (u = v = 0.5, +X).
    const Image scaled = remap_latlong(src, {3, 0, 0, 0, 3, 0, 0, 0, 3}, {0, 0, 0});
    for (size_t k = 0; k < src.pixels.size(); ++k) ASSERT_NEAR(scaled.pixels[k], src.pixels[k], 1e-5f);
    const Image zero = remap_latlong(src, {0, 0, 0, 0, 0, 0, 0, 0, 0}, {0, 0, 0});
    float mid[3];
    latlong_bilinear(src, {1, 0, 0}, mid);
    for (int k = 0; k < 3; ++k) EXPECT_FLOAT_EQ(zero.at(5, 7)[k], mid[k]);
}

// The SH9 the bake reports (project_sh9_bilinear) is that of SPEC's L, the
// bilinear reconstruction, not of texel-constant radiance: against a
// midpoint rule over (phi, s = sin lat), where dOmega = dphi ds, of
// latlong_bilinear (SPEC section 1's lookup) times the basis, on a small
// random world with one bright texel, where the two reconstructions' SH9
// differ by far more than the rule's error. A BinRowStream over bands of
// rows and build_bin_tree's reduction give the same bits, at any thread
// count; a constant world gives the DC alone.
TEST(Source, BilinearSh9IsTheIntegralOfSpecsL) {
    const int w = 24, h = 12;
    Image img = ref::random_smooth_source(w, h, 5);
    img.at(7, 3)[0] = 40.0f;
    img.at(19, 0)[2] = 25.0f;  // the top row: L constant from its centre to the pole
    // Nodes in (phi, lat), dOmega = cos(lat) dlat dphi, the midpoint rule
    // within each cell between texel centres (and each polar cap), where L
    // is smooth: 128 x 128 nodes a cell.
    const int m = 128;
    std::vector<double> phis, lats, lat_w;
    for (int x = 0; x < w; ++x)
        for (int i = 0; i < m; ++i) phis.push_back(2.0 * kPi * (x + 0.5 + (i + 0.5) / m) / w);
    const double row_h = kPi / h;
    auto cell = [&](double lat0, double lat1) {
        for (int j = 0; j < m; ++j) {
            const double lat = lat0 + (lat1 - lat0) * (j + 0.5) / m;
            lats.push_back(lat);
            lat_w.push_back(std::cos(lat) * (lat1 - lat0) / m);
        }
    };
    cell(-0.5 * kPi, -0.5 * kPi + 0.5 * row_h);
    for (int y = 0; y + 1 < h; ++y) cell(-0.5 * kPi + (y + 0.5) * row_h, -0.5 * kPi + (y + 1.5) * row_h);
    cell(0.5 * kPi - 0.5 * row_h, 0.5 * kPi);
    // And of texel-constant radiance (each direction's own texel), which
    // the test must tell apart.
    auto texel_of = [&](const Vec3d& d) {
        const LatLongUV uv = direction_to_latlong(engine_to_blender(d));
        const int x = std::clamp(int(std::floor(uv.u * w)), 0, w - 1);
        const int y = std::clamp(int(std::floor((1.0 - uv.v) * h)), 0, h - 1);
        return img.at(x, y);
    };
    std::array<Sh9, 3> want{}, box{};
    for (size_t j = 0; j < lats.size(); ++j) {
        const double s = std::sin(lats[j]), c = std::cos(lats[j]);
        for (double phi : phis) {
            const Vec3d d = blender_to_engine(Vec3d{c * std::cos(phi), c * std::sin(phi), s});
            float L[3];
            latlong_bilinear(img, d, L);
            const Sh9 y = sh9_basis(d);
            const float* T = texel_of(d);
            for (int ch = 0; ch < 3; ++ch)
                for (int k = 0; k < 9; ++k) {
                    want[ch][k] += L[ch] * y[k] * lat_w[j];
                    box[ch][k] += T[ch] * y[k] * lat_w[j];
                }
        }
    }
    const double d_phi = 2.0 * kPi / double(phis.size());
    for (auto* sh : {&want, &box})
        for (auto& ch : *sh)
            for (double& v : ch) v *= d_phi;
    const std::array<Sh9, 3> got = project_sh9_bilinear(img, 8);
    double worst_box = 0.0;
    for (int ch = 0; ch < 3; ++ch) {
        const double scale = std::abs(want[ch][0]);
        for (int k = 0; k < 9; ++k) {
            EXPECT_NEAR(got[ch][k], want[ch][k], 1e-6 * scale) << ch << " " << k;
            worst_box = std::max(worst_box, std::abs(box[ch][k] - want[ch][k]) / scale);
        }
    }
    EXPECT_GT(worst_box, 1e-3) << "texel-constant radiance's SH9 would pass: the test does not tell them apart";
    // Any bin width gives the same integral (to float's rounding of the column sums).
    for (int bw : {2, 4, 16, 32}) {
        const std::array<Sh9, 3> other = project_sh9_bilinear(img, bw);
        for (int ch = 0; ch < 3; ++ch)
            for (int k = 0; k < 9; ++k)
                EXPECT_NEAR(other[ch][k], got[ch][k], kFloatSums * std::abs(got[ch][0])) << bw;
    }
    // The same bits from a stream of bands and from the tree's reduction.
    for (int bw : {8, 16}) {
        const std::array<Sh9, 3> whole = project_sh9_bilinear(img, bw);
        BinRowStream stream(w, h, bw);
        for (int y0 = 0; y0 < h; y0 += 4) stream.add_rows(img, std::max(0, y0 - stream.max_reach()), std::min(h - 1, y0 + 3));
        ASSERT_EQ(stream.pending(), 0);
        EXPECT_EQ(std::memcmp(stream.sh9().data(), whole.data(), sizeof(whole)), 0) << bw;
        std::array<Sh9, 3> from_tree{};
        BinTreeOptions options;
        options.sh9 = &from_tree;
        build_bin_tree(img, bw, nullptr, 0, options);
        EXPECT_EQ(std::memcmp(from_tree.data(), whole.data(), sizeof(whole)), 0) << bw;
        // And from reduce_to_bins' (a whole bake's irradiance bins without a
        // tree), whose bins are those it makes without the SH9.
        std::array<Sh9, 3> from_bins{};
        const std::vector<Bin> bins = reduce_to_bins(img, bw, bw / 2, &from_bins), plain = reduce_to_bins(img, bw, bw / 2);
        EXPECT_EQ(std::memcmp(from_bins.data(), whole.data(), sizeof(whole)), 0) << bw;
        ASSERT_EQ(bins.size(), plain.size());
        EXPECT_EQ(std::memcmp(bins.data(), plain.data(), bins.size() * sizeof(Bin)), 0) << bw;
    }
    std::array<Sh9, 3> from_nothing{};
    EXPECT_THROW(BinReduction(img, 8, 4).row(0, std::vector<Bin>(8).data(), &from_nothing), std::logic_error);
    const std::array<Sh9, 3> flat = project_sh9_bilinear(ref::constant_source(64, 32, 2.0f), 16);
    for (int ch = 0; ch < 3; ++ch) {
        EXPECT_NEAR(flat[ch][0], 0.282095 * 2.0 * 4.0 * kPi, kFloatSums * flat[ch][0]);
        for (int k = 1; k < 9; ++k) EXPECT_NEAR(flat[ch][k], 0.0, kFloatSums * flat[ch][0]) << k;
    }
}
