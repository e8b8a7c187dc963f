// ibl: the integrators (the source and its summaries, bins, irradiance,
// specular, the BRDF LUT), each from images to cubes or tables. Above image/;
// beside io/, which it never includes: no integrator reads or writes a file.
//
// The source environment: cleaning bad texels, lookups, the split into a
// bounded "rest" and exactly-integrated "hot" texels, energy-exact reduction
// to weighted points, SH projection. All directions returned are engine
// space (SPEC.md section 2); the image is Blender lat-long (section 1).
#pragma once
#include <atomic>
#include <array>
#include <limits>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/math/latlong.h"
#include "iblbake/math/sh.h"
#include "iblbake/math/vec3.h"

namespace iblbake {

struct BadInputCounts {
    uint64_t nan = 0, inf = 0, negative = 0, pixels = 0;
    bool any() const { return pixels != 0; }
};

// Count NaN, +-Inf and negative channel values and set them to 0 (SPEC.md 1).
BadInputCounts sanitize(Image& img);

// One read-only pass over a source: what sanitize() would count, and the
// largest value it would keep (finite, >= 0). A clean source then needs no
// copy at all.
struct SourceScan {
    BadInputCounts bad;
    float max_value = 0.0f;
    std::vector<int> bad_rows;  // rows holding bad values, ascending
};
SourceScan scan_source(ImageView img);

// sanitize() with the scan done: cleans the scan's bad rows in place.
void clean_bad_rows(Image& img, const SourceScan& scan);

// A view of `img` whose rows `rows` (ascending) are copies in `store`, for
// the caller to change (row k of the list at store + k * width * 3); every
// other row is `img`'s own, through the view's row table `row_table`.
ImageView view_with_copied_rows(ImageView img, const std::vector<int>& rows, std::vector<float>& store,
                                std::vector<const float*>& row_table);

// A view of `img` as sanitize() would leave it, without copying the image:
// the scan's bad rows are copied into `store` and cleaned there, and the
// view's row table (`row_table`) points every other row at `img`.
ImageView sanitized_view(ImageView img, const SourceScan& scan, std::vector<float>& store,
                         std::vector<const float*>& row_table);

// Bilinear reconstruction L(w) of SPEC.md section 1 (wraps in u, clamps rows),
// for an engine-space direction.
void latlong_bilinear(ImageView img, const Vec3d& engine_dir, float out[3]);

// SPEC's L(w) (bilinear) sampled at the texel centres of a w x h lat-long
// grid: integrals of the result with texel-constant radiance approach those
// of the bilinear L as the grid gets finer. Used to bring small sources up
// to the resolution the integrators need.
Image resample_latlong(ImageView img, int w, int h);

// The lat-long image seen through an affine change of lookup direction, as
// Blender's Mapping node feeding an Environment Texture does it: texel (x, y)
// of the result holds L(normalize(A d + b)), d its centre's Blender direction,
// A row-major 3x3. Same size as `img`; a zero vector reads the centre
// (u = v = 0.5).
Image remap_latlong(ImageView img, const std::array<double, 9>& a, const std::array<double, 3>& b);

// A source texel (or a block of them) as a point: engine direction and power
// (radiance times solid angle) per channel.
struct RadiancePoint {
    float dir[3];       // centre direction
    float mean_dir[3];  // (integral of w over the texel's hat) / its integral: |mean_dir| < 1
    float power[3];
    float cov[6];       // covariance of w over the texel's hat (engine space: xx, yy, zz, xy, xz, yz)
};

// The split L = rest + hot. Every texel whose largest channel m exceeds the
// threshold keeps rest = L * threshold / m and gives the excess to `hot`, a
// list of points at its centre direction. The threshold is the larger of
// `relative_threshold` times the solid-angle-weighted mean of m and the value
// that leaves at most `max_hot` texels above it. The rest is not copied:
// `texels` says what each hot texel gave (rest_image() and
// reduce_rest_to_bins() apply it).
struct HotTexel {
    int x, y;
    float removed[3];  // radiance moved from the texel to its hot point
};
struct HotSplit {
    std::vector<HotTexel> texels;
    std::vector<RadiancePoint> hot;  // one per entry of `texels`
    double threshold = 0.0;
    double hot_power_fraction = 0.0;  // hot power / total power (luminance-free: sum of channels)
};
// Per row of a source, what the split needs first: the solid-angle weighted
// sums of each texel's largest channel and of all channels, and the row's
// largest channel.
struct HotRows {
    std::vector<double> mean, power;
    std::vector<float> top;
    std::vector<double> channel;  // row y's power per channel at 3 y + c (float sums along the row)
};
// Per channel, the mean radiance of texel-constant L from the hot rows'
// channel sums (rows added in order): the bin tree's chroma floor.
std::array<double, 3> channel_means(const HotRows& rows);
HotRows hot_rows(ImageView img);
// `rows`, when given, must be hot_rows(img) (computed in another pass).
HotSplit split_hot(ImageView img, double relative_threshold, int max_hot, const HotRows* rows = nullptr);
// The rest image, L minus what the hot texels gave.
Image rest_image(ImageView img, const HotSplit& split);

// An energy-exact reduction of a lat-long image to a grid of bw x bh bins
// overlaid on it (any sizes, 1 x 1 included): every bin holds the exact
// integrals of SPEC.md's L, the bilinear reconstruction, over its rectangle
// (sums of texel values times products of hat integrals, math/latlong.h).
struct Bin {
    double vector[3][3];  // per channel: integral of L_c w dOmega (engine space)
    double power[3];      // per channel: integral of L_c dOmega
    // Integral of (L_r + L_g + L_b) w w^T dOmega (engine space): xx, yy, zz, xy, xz, yz.
    double second[6];
    // (A bin's geometry, its solid angle and first moment, is that of its
    // rectangle alone: rect_solid_angle and rect_moment, math/latlong.h.)
};
// With sh9: also project_sh9_bilinear(img, bw) (bh = bw / 2), to the bit, from
// the same reduction.
std::vector<Bin> reduce_to_bins(ImageView img, int bw, int bh, std::array<Sh9, 3>* sh9 = nullptr);
// The same reduction one bin row at a time: rows are independent, so a caller
// can run them in parallel and keep only what it needs of each. sh9: rows
// may be asked for their SH9 (the longitude hats' tables are made).
class BinReduction {
public:
    // row() reduces chunk_columns columns at a time (a multiple of 16): any
    // chunk gives the same bits; the default keeps a chunk's column sums,
    // 120 KB, in L2.
    static constexpr int kChunkColumns = 1024;
    BinReduction(ImageView img, int bw, int bh, bool sh9 = false, int chunk_columns = kChunkColumns);
    int width() const { return bw_; }
    int height() const { return bh_; }
    // Bins (0..bw-1, br), overwritten; with sh9, also the bin row's part of
    // the SH9 of SPEC's bilinear L (project_sh9_bilinear): bands 0 and 1 the
    // sums of its bins' power and vectors, band 2 from the column sums the
    // bins are made of (kernel::sh9_band2_fn, the longitude hats'
    // integrals in closed form).
    void row(int br, Bin* out, std::array<Sh9, 3>* sh9 = nullptr) const;
    // The same from another image of the same size (only the rows
    // source_rows(br) are read: a view of a band of rows serves).
    void row(ImageView img, int br, Bin* out, std::array<Sh9, 3>* sh9 = nullptr) const;
    std::pair<int, int> source_rows(int br) const;  // first and last row bin row br reads

private:
    ImageView img_;
    int bw_, bh_;
    std::vector<HatPiece> cols_, rows_;  // cols_ grouped by column chunk (row())
    std::vector<size_t> first_;  // first row piece of each bin row
    int chunk_;                        // columns per chunk
    std::vector<size_t> chunk_first_;  // first column piece of each chunk of columns
    std::vector<double> hat_[4];  // kernel::sh9_hat_tables (empty without sh9)
    double p0_ = 0.0;
};
// o += b, every integral.
void add_bins(Bin& o, const Bin& b);
// The same reduction at bw/2 x bh/2 (even sizes): 2 x 2 blocks summed, exactly.
std::vector<Bin> coarsen_bins(const std::vector<Bin>& bins, int bw, int bh);
// reduce_to_bins(rest_image(img, split), bw, bh) without making the rest image:
// the hot texels' gifts are taken out of the bins they overlap.
std::vector<Bin> reduce_rest_to_bins(ImageView img, const HotSplit& split, int bw, int bh);
// Takes the hot texels' gifts out of bw x bh bins of an img_w x img_h image.
void remove_hot(std::vector<Bin>& bins, int bw, int bh, int img_w, int img_h, const HotSplit& split);

// Per channel, the 9 SH coefficients (SPEC.md section 5) of SPEC's L, the
// bilinear reconstruction: what the bake reports.
// Summed bin row by bin row of the bins BinReduction(img, w, w / 2) makes,
// w = max(2, bw), in row order; a BinRowStream of that width over the same
// rows gives the same bits (its sh9()), and so does build_bin_tree's
// (BinTreeOptions::sh9). Exact for any L whose SH9 is band-limited to
// band 2 in each row's bilinear pieces (the longitude hats' integrals in
// closed form, kernel::sh9_hat_tables).
std::array<Sh9, 3> project_sh9_bilinear(ImageView img, int bw);
// The sum of per-row projections, in row order.
std::array<Sh9, 3> sum_sh9_rows(const std::vector<std::array<Sh9, 3>>& rows);

// scan_source and hot_rows in one pass over the rows: each row is read from
// memory once and used twice while in cache (the passes of a 400 MB source
// are memory-bound). The results are those of the two functions; the hot
// rows describe the source as it is, so a source the scan finds bad (or
// past the overflow guard) needs them again once cleaned:
// refresh_summary_rows redoes the bad rows alone.
struct SourceSummary {
    SourceScan scan;
    HotRows hot;
};
SourceSummary summarize_source(ImageView img);
// After the rows `rows` of the source changed (cleaned), with every other
// row as summarized: those rows' hot-row sums again from `img`. Equal to
// the bit to hot_rows(img).
void refresh_summary_rows(SourceSummary& s, ImageView img, const std::vector<int>& rows);

// summarize_source() and the cleaning, as a source is decoded in bands
// (issue 28, docs/design-streaming.md): add_rows() scans rows y0 .. y0+n-1
// (bad values counted as scan_source counts them), cleans their bad values
// in place (as clean_bad_rows does) and summarizes the cleaned rows. Rows
// may come in any order, each once. finish() (every row added) gives, to the
// bit, what summarize_source(img) followed by clean_bad_rows and
// refresh_summary_rows(.., cleaned img, scan.bad_rows) give: the bake's
// scan() and sanitize() when the overflow guard is off.
class SummaryStream {
public:
    SummaryStream(int width, int height);
    ~SummaryStream();
    SummaryStream(const SummaryStream&) = delete;
    SummaryStream& operator=(const SummaryStream&) = delete;
    // rows[k]: row y0 + k, width x 3 floats, cleaned in place. Rows in
    // parallel. With `hots`, each cleaned row also goes to hots while it is
    // in the cache (what hots->add_rows would do after this call, to the bit).
    // With `halves`, rows[k] is first filled from halves + k x width x 3
    // (IEEE binary16, RGB interleaved: halves_to_floats) by the task that
    // then reduces it.
    void add_rows(float* const* rows, int y0, int n, class HotStream* hots = nullptr,
                  const uint16_t* halves = nullptr);
    SourceSummary finish();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// split_hot as a source is decoded in bands (issue 28): add_rows() keeps the
// max_hot + 1 texels of largest max channel seen so far (value, place,
// colour: 24 bytes each), which is all the threshold and the hot texels
// need; finish() with the summary's hot rows (the mean) gives what
// split_hot(img, relative_threshold, max_hot, &rows) gives, to the bit.
// Rows of clean values, each once, in any order.
class HotStream {
public:
    HotStream(int width, int height, int max_hot);
    ~HotStream();
    HotStream(const HotStream&) = delete;
    HotStream& operator=(const HotStream&) = delete;
    void add_rows(const float* const* rows, int y0, int n);
    // add_rows in three steps, for a pass that reads the rows for other
    // work too (SummaryStream::add_rows): begin_rows, then add_row for each
    // k in 0 .. n-1 (in parallel, each once), then end_rows.
    void begin_rows(int y0, int n);
    // row_top: the row's largest max channel (hot_rows' top) when known:
    // a row whose top is not above the heap's floor has no candidate.
    void add_row(int k, const float* row, float row_top = std::numeric_limits<float>::infinity());
    void end_rows();
    HotSplit finish(double relative_threshold, const HotRows& rows);
    struct Entry;

private:
    int w_, h_;
    size_t keep_;
    std::vector<Entry> top_;  // a heap, its smallest in front
    // The rows between begin_rows and end_rows: their first row, the heap's
    // floor when they began, and each row's candidates.
    int y0_ = 0;
    float floor_ = -1.0f;
    std::atomic<float> row_floor_{-1.0f};  // floor_, raised by the rows added since (add_row)
    std::vector<std::vector<Entry>> found_;
};


}  // namespace iblbake
