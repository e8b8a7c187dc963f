#include "iblbake/ibl/source.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>


#include "iblbake/math/cube.h"
#include "iblbake/math/half.h"
#include "iblbake/math/latlong.h"
#include "iblbake/util/parallel.h"
#include "specular_kernel.h"

namespace iblbake {

namespace {

// Per-image direction tables: cos/sin of longitude per column, of latitude
// per row, and each row's exact texel solid angle.
struct LatLongTables {
    std::vector<double> cos_phi, sin_phi, cos_lat, sin_lat, omega;
    LatLongTables(int w, int h) : cos_phi(w), sin_phi(w), cos_lat(h), sin_lat(h), omega(h) {
        for (int x = 0; x < w; ++x) {
            const double phi = (0.5 - (x + 0.5) / w) * 2.0 * kPi;
            cos_phi[x] = std::cos(phi);
            sin_phi[x] = std::sin(phi);
        }
        for (int y = 0; y < h; ++y) {
            const double l = (0.5 - (y + 0.5) / h) * kPi;
            cos_lat[y] = std::cos(l);
            sin_lat[y] = std::sin(l);
            omega[y] = latlong_row_solid_angle(y, w, h);
        }
    }
    // Engine-space direction of texel (x, y).
    Vec3d engine_dir(int x, int y) const {
        return blender_to_engine(Vec3d{cos_lat[y] * cos_phi[x], cos_lat[y] * sin_phi[x], sin_lat[y]});
    }
};

inline float max3(const float* p) { return std::max(p[0], std::max(p[1], p[2])); }

}  // namespace

namespace {

// Every value not finite and >= 0 becomes 0 (SPEC.md section 1); src may be dst.
void clean_values(const float* src, float* dst, size_t n) {
    for (size_t i = 0; i < n; ++i) dst[i] = src[i] >= 0.0f && src[i] <= FLT_MAX ? src[i] : 0.0f;
}

}  // namespace

void clean_bad_rows(Image& img, const SourceScan& scan) {
    for (int y : scan.bad_rows) clean_values(img.at(0, y), img.at(0, y), size_t(img.width) * 3);
}

BadInputCounts sanitize(Image& img) {
    const SourceScan scan = scan_source(img);
    clean_bad_rows(img, scan);
    return scan.bad;
}

namespace {

// The row loops below are compiled for AVX-512, AVX2 and baseline x86-64,
// the best chosen when the program loads (GCC's target_clones): they only
// compare and add, so every version gives the same bits.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define IBLBAKE_ROW_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define IBLBAKE_ROW_CLONES
#endif

// The largest of n floats' bits, each masked by `mask`, as unsigned
// integers (one vectorised max; inlined into each clone of its callers).
__attribute__((always_inline)) inline uint32_t max_bits(const float* v, int n, uint32_t mask) {
    uint32_t top = 0;
    for (int k = 0; k < n; ++k) {
        uint32_t bits;
        std::memcpy(&bits, v + k, sizeof(bits));
        top = std::max(top, bits & mask);
    }
    return top;
}

// One row of scan_source into s.
IBLBAKE_ROW_CLONES void scan_row(const float* row, int width, SourceScan& s) {
    const int n = 3 * width;
    // Fast path, one vectorised unsigned max of the bits: finite values
    // >= 0 order as their bits do and stay below Inf's 0x7f800000, while
    // NaN, Inf and anything with the sign bit set (-0 included, which the
    // slow path then keeps) land at or above it.
    const uint32_t top = max_bits(row, n, ~0u);
    if (top < 0x7f800000u) {
        std::memcpy(&s.max_value, &top, sizeof(top));
        return;
    }
    // A row with bad values: each value classed by its bits, without a
    // branch (a 16K row with a few negative values spent a third of the
    // scan's time here): NaN, +-Inf, finite below 0 (not -0); the largest of
    // the rest (-0 as +0) by their bits, as above. Blocks of kScanBlock
    // pixels with no such value take the vectorised max alone (a resized
    // 16K world has a negative value in one row of four, a few in a row).
    constexpr int kScanBlock = 16;
    uint32_t nan = 0, inf = 0, negative = 0, pixels = 0, good_top = 0;
    std::memcpy(&good_top, &s.max_value, sizeof(good_top));  // s is fresh: +0
    for (int x0 = 0; x0 < width; x0 += kScanBlock) {
        const int x1 = std::min(width, x0 + kScanBlock);
        const uint32_t block_top = max_bits(row + 3 * x0, 3 * (x1 - x0), ~0u);
        if (block_top < 0x7f800000u) {
            good_top = std::max(good_top, block_top);
            continue;
        }
        for (int x = x0; x < x1; ++x) {
            uint32_t bad = 0;
            for (int k = 0; k < 3; ++k) {
                uint32_t u;
                std::memcpy(&u, row + 3 * x + k, sizeof(u));
                const uint32_t a = u & 0x7fffffffu, sign = u >> 31;
                const uint32_t is_nan = a > 0x7f800000u, is_inf = a == 0x7f800000u;
                const uint32_t is_neg = sign & uint32_t(a != 0u) & uint32_t(a < 0x7f800000u);
                nan += is_nan;
                inf += is_inf;
                negative += is_neg;
                bad |= is_nan | is_inf | is_neg;
                good_top = std::max(good_top, (is_nan | is_inf | sign) ? 0u : u);
            }
            pixels += bad;
        }
    }
    s.bad.nan += nan;
    s.bad.inf += inf;
    s.bad.negative += negative;
    s.bad.pixels += pixels;
    std::memcpy(&s.max_value, &good_top, sizeof(good_top));
}

SourceScan combine_scans(const std::vector<SourceScan>& rows) {
    const int h = int(rows.size());
    SourceScan total;
    for (int y = 0; y < h; ++y) {
        const SourceScan& s = rows[y];
        if (s.bad.pixels) total.bad_rows.push_back(y);
        total.bad.nan += s.bad.nan;
        total.bad.inf += s.bad.inf;
        total.bad.negative += s.bad.negative;
        total.bad.pixels += s.bad.pixels;
        total.max_value = std::max(total.max_value, s.max_value);
    }
    return total;
}

}  // namespace

SourceScan scan_source(ImageView img) {
    std::vector<SourceScan> rows(img.height);
    parallel_for(0, img.height, [&](int y) { scan_row(img.at(0, y), img.width, rows[y]); });
    return combine_scans(rows);
}

ImageView view_with_copied_rows(ImageView img, const std::vector<int>& rows, std::vector<float>& store,
                                std::vector<const float*>& row_table) {
    const size_t n = size_t(img.width) * 3;
    store.resize(rows.size() * n);
    row_table.resize(img.height);
    for (int y = 0; y < img.height; ++y) row_table[y] = img.at(0, y);
    for (size_t k = 0; k < rows.size(); ++k) {
        std::copy_n(img.at(0, rows[k]), n, store.data() + k * n);
        row_table[rows[k]] = store.data() + k * n;
    }
    ImageView v = img;
    v.rows = row_table.data();
    return v;
}

ImageView sanitized_view(ImageView img, const SourceScan& scan, std::vector<float>& store,
                         std::vector<const float*>& row_table) {
    if (scan.bad_rows.empty()) return img;
    const ImageView v = view_with_copied_rows(img, scan.bad_rows, store, row_table);
    const size_t n = size_t(img.width) * 3;
    for (size_t k = 0; k < scan.bad_rows.size(); ++k) clean_values(store.data() + k * n, store.data() + k * n, n);
    return v;
}

void latlong_bilinear(ImageView img, const Vec3d& engine_dir, float out[3]) {
    const LatLongUV uv = direction_to_latlong(engine_to_blender(engine_dir));
    const int w = img.width, h = img.height;
    const double fx = uv.u * w - 0.5, fy = (1.0 - uv.v) * h - 0.5;
    const double x0f = std::floor(fx), y0f = std::floor(fy);
    const double tx = fx - x0f, ty = fy - y0f;
    int x0 = int(x0f) % w;
    if (x0 < 0) x0 += w;
    const int x1 = (x0 + 1) % w;
    const int y0 = std::clamp(int(y0f), 0, h - 1), y1 = std::clamp(int(y0f) + 1, 0, h - 1);
    const float* a = img.at(x0, y0);
    const float* b = img.at(x1, y0);
    const float* c = img.at(x0, y1);
    const float* d = img.at(x1, y1);
    for (int k = 0; k < 3; ++k) {
        const double top = a[k] + (b[k] - a[k]) * tx;
        const double bottom = c[k] + (d[k] - c[k]) * tx;
        out[k] = float(top + (bottom - top) * ty);
    }
}

Image resample_latlong(ImageView img, int w, int h) {
    Image out(w, h);
    parallel_for(0, h, [&](int y) {
        for (int x = 0; x < w; ++x)
            latlong_bilinear(img, blender_to_engine(latlong_texel_direction(x, y, w, h)), out.at(x, y));
    });
    return out;
}

Image remap_latlong(ImageView img, const std::array<double, 9>& a, const std::array<double, 3>& b) {
    const int w = img.width, h = img.height;
    Image out(w, h);
    parallel_for(0, h, [&](int y) {
        for (int x = 0; x < w; ++x) {
            const Vec3d d = latlong_texel_direction(x, y, w, h);
            Vec3d m{a[0] * d.x + a[1] * d.y + a[2] * d.z + b[0], a[3] * d.x + a[4] * d.y + a[5] * d.z + b[1],
                    a[6] * d.x + a[7] * d.y + a[8] * d.z + b[2]};
            if (!(length(m) > 0.0)) m = {1.0, 0.0, 0.0};  // degenerate: the image centre (u = v = 0.5)
            latlong_bilinear(img, blender_to_engine(m), out.at(x, y));
        }
    });
    return out;
}

namespace {
void add_hat_product(Bin& b, const double v[3], const double* s0, const double* s1, const double* s2,
                     const double* c0, const double* c1, const double U[6]);
}  // namespace

namespace {

// Row y of hot_rows (float lanes, double across them), into `out`.
IBLBAKE_ROW_CLONES void hot_row(const float* row, int w, int y, const LatLongTables& tab, HotRows& out) {
    constexpr int kLanes = 16;
    float sm[kLanes] = {}, sp[kLanes] = {}, top[kLanes] = {}, sc[3][kLanes] = {};
    const int whole = w / kLanes * kLanes;
    for (int x0 = 0; x0 < whole; x0 += kLanes)
        for (int l = 0; l < kLanes; ++l) {
            const float* px = row + size_t(x0 + l) * 3;
            const float m = max3(px);
            sm[l] += m;
            sp[l] += px[0] + px[1] + px[2];
            top[l] = std::max(top[l], m);
            for (int c = 0; c < 3; ++c) sc[c][l] += px[c];
        }
    for (int x = whole; x < w; ++x) {
        const float* px = row + size_t(x) * 3;
        sm[0] += max3(px);
        sp[0] += px[0] + px[1] + px[2];
        top[0] = std::max(top[0], max3(px));
        for (int c = 0; c < 3; ++c) sc[c][0] += px[c];
    }
    double s = 0.0, p = 0.0, ch[3] = {0.0, 0.0, 0.0};
    float t = 0.0f;
    for (int l = 0; l < kLanes; ++l) {
        s += sm[l];
        p += sp[l];
        t = std::max(t, top[l]);
        for (int c = 0; c < 3; ++c) ch[c] += sc[c][l];
    }
    out.mean[y] = s * tab.omega[y];
    out.power[y] = p * tab.omega[y];
    out.top[y] = t;
    for (int c = 0; c < 3; ++c) out.channel[size_t(3) * y + c] = ch[c] * tab.omega[y];
}

HotRows sized_hot_rows(int h) {
    HotRows r;
    r.mean.resize(h);
    r.power.resize(h);
    r.top.resize(h);
    r.channel.resize(size_t(3) * h);
    return r;
}

}  // namespace

std::array<double, 3> channel_means(const HotRows& rows) {
    std::array<double, 3> mean{};
    const size_t h = rows.channel.size() / 3;
    for (size_t y = 0; y < h; ++y)
        for (int c = 0; c < 3; ++c) mean[c] += rows.channel[3 * y + c];
    for (double& m : mean) m /= 4.0 * kPi;
    return mean;
}

HotRows hot_rows(ImageView img) {
    const LatLongTables tab(img.width, img.height);
    HotRows r = sized_hot_rows(img.height);
    parallel_for(0, img.height, [&](int y) { hot_row(img.at(0, y), img.width, y, tab, r); });
    return r;
}

// A texel that may be hot: its largest channel, where, its value (split_hot's
// candidates, and the texels HotStream keeps).
struct HotStream::Entry {
    float m;
    int x, y;
    float rgb[3];
};

namespace {

// The columns and the rows of some texels (anything with x and y), in their
// order: the `only` of hat_pieces_lon/lat for the hot texels.
template <typename Texel>
std::pair<std::vector<int>, std::vector<int>> columns_and_rows(const std::vector<Texel>& texels) {
    std::pair<std::vector<int>, std::vector<int>> xy;
    for (const Texel& t : texels) {
        xy.first.push_back(t.x);
        xy.second.push_back(t.y);
    }
    return xy;
}

// split_hot's points of the texels above out.threshold (given in row-major
// order), and the hot power's fraction of total_power.
void make_hot_points(HotSplit& out, int w, int h, const std::vector<HotStream::Entry>& hot, double total_power) {
    const LatLongTables tab(w, h);
    // A texel's value reaches the sphere through its hats (SPEC's bilinear
    // L): its point carries the hats' integrals (over the whole sphere).
    // (Each texel's one piece of the single bin, for the hot texels alone.)
    const auto [xs, ys] = columns_and_rows(hot);
    std::vector<const double*> lon_hat(size_t(w), nullptr), lat_hat(size_t(h), nullptr);
    const std::vector<HatPiece> lon_hats = hat_pieces_lon(w, 1, xs), lat_hats = hat_pieces_lat(h, 1, ys);
    for (const HatPiece& p : lon_hats) lon_hat[size_t(p.texel)] = p.w;
    for (const HatPiece& p : lat_hats) lat_hat[size_t(p.texel)] = p.w;
    double hot_power = 0.0;
    const double threshold = out.threshold;
    for (const HotStream::Entry& c : hot) {
        const int x = c.x, y = c.y;
        const float* px = c.rgb;
        const float scale = float(threshold / c.m);
        HotTexel t{x, y, {0, 0, 0}};
        RadiancePoint p;
        const Vec3d d = tab.engine_dir(x, y);
        const double* U = lon_hat[size_t(x)];
        const double* V = lat_hat[size_t(y)];
        const double om = U[0] * V[0];
        const Vec3d md = Vec3d{U[1] * V[3], U[0] * V[1], -U[2] * V[3]} / om;
        p.dir[0] = float(d.x); p.dir[1] = float(d.y); p.dir[2] = float(d.z);
        p.mean_dir[0] = float(md.x); p.mean_dir[1] = float(md.y); p.mean_dir[2] = float(md.z);
        {
            Bin one{};
            const double unit[3] = {1.0, 0.0, 0.0}, s0[3] = {V[0], 0, 0}, s1[3] = {V[1], 0, 0},
                         s2[3] = {V[2], 0, 0}, c0[3] = {V[3], 0, 0}, c1[3] = {V[4], 0, 0};
            add_hat_product(one, unit, s0, s1, s2, c0, c1, U);
            const double* sm = one.second;
            const double cv[6] = {sm[0] / om - md.x * md.x, sm[1] / om - md.y * md.y, sm[2] / om - md.z * md.z,
                                  sm[3] / om - md.x * md.y, sm[4] / om - md.x * md.z, sm[5] / om - md.y * md.z};
            for (int k = 0; k < 6; ++k) p.cov[k] = float(cv[k]);
        }
        for (int k = 0; k < 3; ++k) {
            const float rest = px[k] * scale;
            t.removed[k] = px[k] - rest;
            p.power[k] = float(double(t.removed[k]) * om);
            hot_power += p.power[k];
        }
        out.texels.push_back(t);
        out.hot.push_back(p);
    }
    out.hot_power_fraction = total_power > 0.0 ? hot_power / total_power : 0.0;
}

}  // namespace

HotSplit split_hot(ImageView img, double relative_threshold, int max_hot, const HotRows* rows) {
    const int w = img.width, h = img.height;
    HotSplit out;
    HotRows own;
    if (!rows) {
        own = hot_rows(img);
        rows = &own;
    }
    const std::vector<double>&row_mean = rows->mean, &row_power = rows->power;
    const std::vector<float>& row_top = rows->top;
    double mean = 0.0, total_power = 0.0;
    for (int y = 0; y < h; ++y) { mean += row_mean[y]; total_power += row_power[y]; }
    mean /= 4.0 * kPi;

    double threshold = relative_threshold * mean;
    // Candidates above the relative threshold, from the rows that hold any,
    // found in parallel and kept in row-major order (the final threshold can
    // only be higher).
    std::vector<std::vector<std::pair<int, float>>> row_cands(h);
    parallel_for(0, h, [&](int y) {
        if (!(row_top[y] > threshold)) return;
        for (int x = 0; x < w; ++x) {
            const float m = max3(img.at(x, y));
            if (m > threshold) row_cands[y].emplace_back(x, m);
        }
    });
    std::vector<float> above;
    for (const auto& rc : row_cands)
        for (const auto& [x, m] : rc) above.push_back(m);
    if (max_hot <= 0) {
        threshold = above.empty() ? threshold : double(*std::max_element(above.begin(), above.end()));
    } else if (int(above.size()) > max_hot) {
        // At most max_hot texels strictly above: the (max_hot+1)-th largest value.
        std::nth_element(above.begin(), above.begin() + max_hot, above.end(), std::greater<float>());
        threshold = above[max_hot];
    }
    out.threshold = threshold;
    std::vector<HotStream::Entry> hot;
    for (int y = 0; y < h; ++y)
        for (const auto& [x, m] : row_cands[y]) {
            if (!(m > threshold)) continue;
            const float* px = img.at(x, y);
            hot.push_back({m, x, y, {px[0], px[1], px[2]}});
        }
    make_hot_points(out, w, h, hot, total_power);
    return out;
}

Image rest_image(ImageView img, const HotSplit& split) {
    Image rest(img.width, img.height);
    for (int y = 0; y < img.height; ++y) std::copy(img.at(0, y), img.at(0, y) + 3 * img.width, rest.at(0, y));
    for (const HotTexel& t : split.texels) {
        float* px = rest.at(t.x, t.y);
        for (int k = 0; k < 3; ++k) px[k] -= t.removed[k];
    }
    return rest;
}

namespace {
// Where each of `groups` groups starts in pieces ordered by group(piece):
// groups + 1 indices, the last pieces.size(); an empty group starts where
// the next one does.
template <typename Group>
std::vector<size_t> group_starts(const std::vector<HatPiece>& pieces, int groups, Group group) {
    std::vector<size_t> first(size_t(groups) + 1, pieces.size());
    for (size_t k = pieces.size(); k-- > 0;) first[size_t(group(pieces[k]))] = k;
    for (int g = groups; g-- > 0;) first[size_t(g)] = std::min(first[size_t(g)], first[size_t(g) + 1]);
    return first;
}
}  // namespace

BinReduction::BinReduction(ImageView img, int bw, int bh, bool sh9, int chunk_columns)
    : img_(img), bw_(std::max(1, bw)), bh_(std::max(1, bh)), chunk_(chunk_columns) {
    // Whole SH9 lanes (8 columns) per chunk, and whole row_pieces blocks (16
    // values; 32 on AVX-512, whose chunk remainder the tail sums) by default.
    if (chunk_ < 16 || chunk_ % 16 != 0) throw std::invalid_argument("BinReduction: chunks of a multiple of 16 columns");
    cols_ = hat_pieces_lon(img.width, bw_);
    rows_ = hat_pieces_lat(img.height, bh_);  // t = 1 - v, from the top
    // Column pieces grouped by the chunk of columns their texel lies in
    // (row() reduces a bin row chunk by chunk), in their order within each.
    // hat_pieces gives a bin's pieces in texel order, the wrapped ones too
    // (bin 0 ends with the last texel, the last bin starts with texel 0), so
    // every bin still adds its pieces in the same order.
    const auto chunk_of = [chunk = chunk_](const HatPiece& p) { return p.texel / chunk; };
    std::stable_sort(cols_.begin(), cols_.end(),
                     [&](const HatPiece& p, const HatPiece& q) { return chunk_of(p) < chunk_of(q); });
    chunk_first_ = group_starts(cols_, (img.width + chunk_ - 1) / chunk_, chunk_of);
    // Row pieces are sorted by bin row: bin rows are independent work.
    first_ = group_starts(rows_, bh_, [](const HatPiece& p) { return p.bin; });
    if (sh9) p0_ = kernel::sh9_hat_tables(img.width, hat_);
}

namespace {

// Adds v (per channel) times the hat product U (longitude) x V (latitude) to
// a bin's integrals. Longitude terms: 1, cos, sin, cos^2, sin^2, sin cos;
// latitude terms: 1, s, s^2, sqrt(1 - s^2), s sqrt(1 - s^2) (math/latlong.h).
// Blender w = (c cos phi, c sin phi, s), engine w = (x, z, -y).
void add_hat_product(Bin& b, const double v[3], const double* s0, const double* s1, const double* s2,
                     const double* c0, const double* c1, const double U[6]) {
    double S0 = 0, S2 = 0, C1 = 0;
    for (int c = 0; c < 3; ++c) {
        b.power[c] += v[c] * s0[c] * U[0];
        b.vector[c][0] += v[c] * c0[c] * U[1];
        b.vector[c][1] += v[c] * s1[c] * U[0];
        b.vector[c][2] -= v[c] * c0[c] * U[2];
        S0 += v[c] * s0[c];
        S2 += v[c] * s2[c];
        C1 += v[c] * c1[c];
    }
    const double q = S0 - S2;  // integral of (1 - s^2) = cos^2(lat)
    b.second[0] += q * U[3];   // xx = B xx
    b.second[1] += S2 * U[0];  // yy = B zz
    b.second[2] += q * U[4];   // zz = B yy
    b.second[3] += C1 * U[1];  // xy = B xz
    b.second[4] -= q * U[5];   // xz = -B xy
    b.second[5] -= C1 * U[2];  // yz = -B yz
}

}  // namespace

// A bin's integrals are sums over its (row piece, column piece) pairs of
// L_xy V_y U_x (math/latlong.h's hats), and only five latitude terms appear.
// So first sum each pixel column over the bin row's row pieces against those
// five terms (contiguous, vectorised), then weigh the column sums by the
// longitude hat integrals once per bin row instead of once per pixel row.
namespace {

// A bin row's row pieces into the five column sums, in float on centred
// weights: S_k[i] = sum over pieces p (in order) of src_p[i] * w_p[k], the
// first product stored, the others added to it, then rebuilt in double
// into the sums of 1, s, s^2, c, s c (kernel::rebuild_sums; the weights
// and why in BinReduction::row). kernel::row_pieces_fn sums blocks of 8 to
// 32 values in registers, the same operations in the same order, so every
// instruction set gives the same bits. A bin row's pieces are a few dozen
// source rows: float keeps each sum to a few parts in 1e7 of the
// magnitudes summed, and everything after is double.
// The last values, fewer than a block: the same sums value by value (built
// for the baseline x86-64: no fused multiply-add).
void add_row_pieces_tail(const float* const* src, const float* w, size_t pieces, size_t i0, size_t n,
                         const double* centre, double* const* out) {
    for (size_t i = i0; i < n; ++i) {
        double S[5], raw[5];
        for (int k = 0; k < 5; ++k) {
            float a = src[0][i] * w[k];
            for (size_t p = 1; p < pieces; ++p) a += src[p][i] * w[5 * p + k];
            S[k] = a;
        }
        kernel::rebuild_sums(S, centre, raw);
        for (int k = 0; k < 5; ++k) out[k][i] = raw[k];
    }
}

// The five sums into out[k] (at least one piece): the whole blocks by
// kernel::row_pieces_fn, built for the CPU's vectors.
void add_row_pieces(const float* const* src, const float* w, size_t pieces, size_t n, const double* centre,
                    double* const* out) {
    add_row_pieces_tail(src, w, pieces, kernel::row_pieces_fn()(src, w, pieces, n, centre, out), n, centre, out);
}

}  // namespace

void BinReduction::row(int br, Bin* out, std::array<Sh9, 3>* sh9) const { row(img_, br, out, sh9); }

namespace {

// A bin row's SH9 (BinReduction::row): its bins' power and vectors (the
// integrals of L and L w, engine space) and the band-2 sums t of
// kernel::sh9_band2_fn, with x = c cos phi, y = s, z = -c sin phi (engine
// space, c = sqrt(1 - s^2); the basis of math/sh.h): xx = sum q pcc,
// pcc = p0 / 2 + h2; zz = sum q (p0 - pcc); yy = p0 sum cs2; xy = sum cc1 h0;
// yz = -sum cc1 h1; xz = -sum q h3.
std::array<Sh9, 3> bin_row_sh9(const Bin* bins, int bw, const double (*t)[6], double p0) {
    std::array<Sh9, 3> out;
    for (int c = 0; c < 3; ++c) {
        double P = 0.0, V[3] = {0.0, 0.0, 0.0};
        for (int b = 0; b < bw; ++b) {
            P += bins[b].power[c];
            for (int k = 0; k < 3; ++k) V[k] += bins[b].vector[c][k];
        }
        const double xx = 0.5 * p0 * t[c][1] + t[c][2], zz = p0 * t[c][1] - xx, yy = p0 * t[c][0];
        const double xy = t[c][4], yz = -t[c][5], xz = -t[c][3];
        out[c] = {0.282095 * P,           0.488603 * V[1], 0.488603 * V[2],
                  0.488603 * V[0],        1.092548 * xy,   1.092548 * yz,
                  0.315392 * (3.0 * zz - P), 1.092548 * xz, 0.546274 * (xx - yy)};
    }
    return out;
}

}  // namespace

std::pair<int, int> BinReduction::source_rows(int br) const {
    int first = std::numeric_limits<int>::max(), last = -1;  // no piece: every band serves
    for (size_t k = first_[br]; k < rows_.size() && rows_[k].bin == br; ++k) {
        first = std::min(first, rows_[k].texel);
        last = std::max(last, rows_[k].texel);
    }
    return {first, last};
}

void BinReduction::row(ImageView img, int br, Bin* out, std::array<Sh9, 3>* sh9) const {
    if (sh9 && hat_[0].empty()) throw std::logic_error("BinReduction::row: SH9 asked of a reduction made without it");
    // Chunk by chunk of columns: a chunk's five column sums (120 KB by
    // default) are weighed by the longitude hats and the SH9 tables while in
    // L2 (a 16K row's, 2 MB, went out to L3 between being summed and read).
    // Each column's sums, each bin's additions and each SH9 lane's are made
    // in the same order as over the whole row: the same bits.
    const int width = img_.width;
    const size_t chunk_n = size_t(std::min(width, chunk_)) * 3;
    thread_local std::vector<double> col;
    col.resize(5 * chunk_n);
    double* cs0 = col.data();
    double* cs1 = cs0 + chunk_n;
    double* cs2 = cs1 + chunk_n;
    double* cc0 = cs2 + chunk_n;
    double* cc1 = cc0 + chunk_n;
    double* const sums[5] = {cs0, cs1, cs2, cc0, cc1};
    thread_local std::vector<const float*> src, at;
    thread_local std::vector<float> w;  // five latitude terms per piece
    src.clear();
    w.clear();
    const double lat_c = (0.5 - (br + 0.5) / bh_) * kPi, s0 = std::sin(lat_c), c0 = std::cos(lat_c);
    const double centre[2] = {s0, c0};
    for (size_t k = first_[br]; k < rows_.size() && rows_[k].bin == br; ++k) {
        const HatPiece& rp = rows_[k];
        src.push_back(img.at(0, rp.texel));
        // The five weights centred on the bin row's middle latitude (s0 =
        // sin, c0 = cos): 1, s - s0, (s - s0)^2, c - c0, (s - s0)(c - c0),
        // each the hat's integral of that term, from its raw ones in double
        // and rounded to float once. The raw sums come back in double
        // (kernel::rebuild_sums).
        // (Raw terms summed in float lost a bin's covariance, its second
        // moment less its mean's square, to cancellation: 64 % off at a
        // sun's edge; centred, a float error in a sum is one of a bin's
        // centre or spread, not of the difference.)
        const double* v = rp.w;
        w.push_back(float(v[0]));
        w.push_back(float(v[1] - s0 * v[0]));
        w.push_back(float(v[2] - 2.0 * s0 * v[1] + s0 * s0 * v[0]));
        w.push_back(float(v[3] - c0 * v[0]));
        w.push_back(float(v[4] - s0 * v[3] - c0 * v[1] + s0 * c0 * v[0]));
    }
    at.resize(src.size());
    std::fill(out, out + bw_, Bin{});
    double lanes[6][24] = {};
    const double one[3] = {1.0, 1.0, 1.0};
    for (size_t c = 0; c + 1 < chunk_first_.size(); ++c) {
        const int x0 = int(c) * chunk_, x1 = std::min(width, x0 + chunk_);
        const size_t n = size_t(x1 - x0) * 3;
        if (src.empty()) {
            std::fill(col.begin(), col.end(), 0.0);  // no row piece reaches this bin row
        } else {
            for (size_t p = 0; p < src.size(); ++p) at[p] = src[p] + size_t(x0) * 3;
            add_row_pieces(at.data(), w.data(), at.size(), n, centre, sums);
        }
        for (size_t k = chunk_first_[c]; k < chunk_first_[c + 1]; ++k) {
            const HatPiece& cp = cols_[k];
            const size_t i = size_t(cp.texel - x0) * 3;
            add_hat_product(out[cp.bin], one, cs0 + i, cs1 + i, cs2 + i, cc0 + i, cc1 + i, cp.w);
        }
        if (sh9) {
            const double* h[4] = {hat_[0].data() + x0, hat_[1].data() + x0, hat_[2].data() + x0,
                                  hat_[3].data() + x0};
            kernel::sh9_band2_fn()(cs0, cs2, cc1, h, size_t(x1 - x0), lanes);
        }
    }
    if (sh9) {
        double t[3][6];
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 6; ++k) {
                double s = 0.0;
                for (int lane = c; lane < 24; lane += 3) s += lanes[k][lane];
                t[c][k] = s;
            }
        *sh9 = bin_row_sh9(out, bw_, t, p0_);
    }
}

std::array<Sh9, 3> project_sh9_bilinear(ImageView img, int bw) {
    const int w = std::max(2, bw);
    const BinReduction red(img, w, w / 2, /*sh9=*/true);
    std::vector<std::array<Sh9, 3>> rows(size_t(red.height()));
    parallel_for(0, red.height(), [&](int br) {
        thread_local std::vector<Bin> bins;
        bins.resize(size_t(red.width()));
        red.row(br, bins.data(), &rows[size_t(br)]);
    });
    return sum_sh9_rows(rows);
}

std::vector<Bin> reduce_to_bins(ImageView img, int bw, int bh, std::array<Sh9, 3>* sh9) {
    const BinReduction red(img, bw, bh, sh9 != nullptr);
    std::vector<Bin> bins(size_t(red.width()) * red.height());
    std::vector<std::array<Sh9, 3>> rows(sh9 ? size_t(red.height()) : 0);
    parallel_for(0, red.height(), [&](int br) {
        red.row(br, &bins[size_t(br) * red.width()], sh9 ? &rows[size_t(br)] : nullptr);
    });
    if (sh9) *sh9 = sum_sh9_rows(rows);
    return bins;
}

void add_bins(Bin& o, const Bin& b) {
    for (int c = 0; c < 3; ++c) {
        for (int k = 0; k < 3; ++k) o.vector[c][k] += b.vector[c][k];
        o.power[c] += b.power[c];
    }
    for (int k = 0; k < 6; ++k) o.second[k] += b.second[k];
}

std::vector<Bin> reduce_rest_to_bins(ImageView img, const HotSplit& split, int bw, int bh) {
    std::vector<Bin> bins = reduce_to_bins(img, bw, bh);
    remove_hot(bins, bw, bh, img.width, img.height, split);
    return bins;
}

void remove_hot(std::vector<Bin>& bins, int bw, int bh, int img_w, int img_h, const HotSplit& split) {
    if (split.texels.empty()) return;
    bw = std::max(1, bw);
    bh = std::max(1, bh);
    // Each hot texel's gift is spread by its hats (SPEC's bilinear L): take
    // it out of every bin its hats reach.
    const auto [xs, ys] = columns_and_rows(split.texels);
    const std::vector<HatPiece> cols = hat_pieces_lon(img_w, bw, xs), rows = hat_pieces_lat(img_h, bh, ys);
    std::vector<std::vector<const HatPiece*>> by_col(img_w), by_row(img_h);
    for (const HatPiece& p : cols) by_col[p.texel].push_back(&p);
    for (const HatPiece& p : rows) by_row[p.texel].push_back(&p);
    for (const HotTexel& t : split.texels) {
        const double neg[3] = {-t.removed[0], -t.removed[1], -t.removed[2]};
        for (const HatPiece* rp : by_row[t.y]) {
            const double* v = rp->w;
            const double s0[3] = {v[0], v[0], v[0]}, s1[3] = {v[1], v[1], v[1]}, s2[3] = {v[2], v[2], v[2]};
            const double c0[3] = {v[3], v[3], v[3]}, c1[3] = {v[4], v[4], v[4]};
            for (const HatPiece* cp : by_col[t.x])
                add_hat_product(bins[size_t(rp->bin) * bw + cp->bin], neg, s0, s1, s2, c0, c1, cp->w);
        }
    }
}

std::vector<Bin> coarsen_bins(const std::vector<Bin>& bins, int bw, int bh) {
    const int w = bw / 2, h = bh / 2;
    std::vector<Bin> out(size_t(w) * h, Bin{});
    parallel_for(0, h, [&](int y) {
        for (int x = 0; x < w; ++x)
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx)
                    add_bins(out[size_t(y) * w + x], bins[size_t(2 * y + dy) * bw + 2 * x + dx]);
    });
    return out;
}

std::array<Sh9, 3> sum_sh9_rows(const std::vector<std::array<Sh9, 3>>& rows) {
    std::array<Sh9, 3> sum{};
    for (const auto& r : rows)
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < 9; ++i) sum[c][i] += r[c][i];
    return sum;
}

double kernel::sh9_hat_tables(int w, std::vector<double> (&h)[4]) {
    const double p0 = 2.0 * kPi / w;
    auto sinc2 = [](double t) {
        const double s = std::sin(t) / t;
        return s * s;
    };
    const double k1 = p0 * sinc2(0.5 * p0), k2 = 0.5 * p0 * sinc2(p0);
    for (auto& v : h) v.resize(size_t(w));
    for (int x = 0; x < w; ++x) {
        const double phi = (0.5 - (x + 0.5) / w) * 2.0 * kPi;
        h[0][x] = k1 * std::cos(phi);
        h[1][x] = k1 * std::sin(phi);
        h[2][x] = k2 * std::cos(2.0 * phi);
        h[3][x] = k2 * std::sin(2.0 * phi);
    }
    return p0;
}

SourceSummary summarize_source(ImageView img) {
    const int w = img.width, h = img.height;
    const LatLongTables tab(w, h);
    SourceSummary out;
    out.hot = sized_hot_rows(h);
    std::vector<SourceScan> scans(h);
    parallel_for(0, h, [&](int y) {
        const float* row = img.at(0, y);
        scan_row(row, w, scans[y]);
        hot_row(row, w, y, tab, out.hot);
    });
    out.scan = combine_scans(scans);
    return out;
}

void refresh_summary_rows(SourceSummary& s, ImageView img, const std::vector<int>& rows) {
    if (rows.empty()) return;
    const int w = img.width, h = img.height;
    const LatLongTables tab(w, h);
    for (int y : rows) hot_row(img.at(0, y), w, y, tab, s.hot);
}

struct SummaryStream::Impl {
    int w, h;
    LatLongTables tab;
    HotRows hot;
    std::vector<SourceScan> scans;
    Impl(int width, int height) : w(width), h(height), tab(width, height), hot(sized_hot_rows(height)), scans(height) {}
};

SummaryStream::SummaryStream(int width, int height) : impl_(std::make_unique<Impl>(width, height)) {}
SummaryStream::~SummaryStream() = default;

void SummaryStream::add_rows(float* const* rows, int y0, int n, HotStream* hots, const uint16_t* halves) {
    Impl& m = *impl_;
    if (hots) hots->begin_rows(y0, n);
    const size_t row_values = size_t(m.w) * 3;
    parallel_for(0, n, [&](int k) {
        const int y = y0 + k;
        float* row = rows[k];
        if (halves) halves_to_floats(halves + size_t(k) * row_values, row, row_values);
        SourceScan& s = m.scans[y];
        s = SourceScan{};
        scan_row(row, m.w, s);
        if (s.bad.pixels) clean_values(row, row, size_t(m.w) * 3);
        hot_row(row, m.w, y, m.tab, m.hot);
        if (hots) hots->add_row(k, row, m.hot.top[y]);
    });
    if (hots) hots->end_rows();
}

SourceSummary SummaryStream::finish() {
    Impl& m = *impl_;
    SourceSummary out;
    out.scan = combine_scans(m.scans);
    out.hot = std::move(m.hot);
    return out;
}

// The heap's order: the largest channel, then the position (any strict
// order does: only the values decide the threshold).
namespace {
bool larger(const HotStream::Entry& a, const HotStream::Entry& b) {
    if (a.m != b.m) return a.m > b.m;
    return a.y != b.y ? a.y < b.y : a.x < b.x;
}

// Cuts a row's candidates (at least `keep`) to its `keep` largest and
// returns the smallest value kept. No texel whose largest channel is not
// above that value can be hot: the row alone has `keep` texels at least as
// bright, and the threshold is at least the keep-th largest value of all.
float keep_largest(std::vector<HotStream::Entry>& f, size_t keep) {
    std::nth_element(f.begin(), f.begin() + std::ptrdiff_t(keep - 1), f.end(), larger);
    f.resize(keep);
    return f[keep - 1].m;
}
}  // namespace

HotStream::HotStream(int width, int height, int max_hot)
    : w_(width), h_(height), keep_(size_t(std::max(0, max_hot)) + 1) {}

HotStream::~HotStream() = default;

void HotStream::add_rows(const float* const* rows, int y0, int n) {
    begin_rows(y0, n);
    parallel_for(0, n, [&](int k) { add_row(k, rows[k]); });
    end_rows();
}

void HotStream::begin_rows(int y0, int n) {
    // Texels above the heap's floor (its smallest once full), per row in
    // parallel, then merged: a stale floor only admits more candidates.
    y0_ = y0;
    floor_ = top_.size() >= keep_ ? top_.front().m : -1.0f;
    row_floor_.store(floor_, std::memory_order_relaxed);
    found_.assign(size_t(n), {});
}

namespace {
// The texels of a clean row whose largest channel is above `floor`, in
// order, at most 2 keep of them: each time there are that many, they are
// cut to the keep largest and the floor raised to the smallest of those
// (keep_largest; a row of a bright sky was 16K candidates, 400 KB, each
// sorted at the end). Blocks of 16 texels whose largest value is not above
// the floor hold none: one vectorised max of the values' bits less the sign
// (clean values are +0 or above, or -0: their magnitudes' bits order as
// they do), the texels looked at one by one only where it is above.
// Returns the floor.
IBLBAKE_ROW_CLONES float hot_candidates(const float* row, int w, float floor, int y, size_t keep,
                                        std::vector<HotStream::Entry>& out) {
    constexpr int kBlock = 16;
    for (int x0 = 0; x0 < w; x0 += kBlock) {
        const int x1 = std::min(w, x0 + kBlock);
        const uint32_t top = max_bits(row + 3 * x0, 3 * (x1 - x0), 0x7fffffffu);
        float block_top;
        std::memcpy(&block_top, &top, sizeof(block_top));
        if (!(block_top > floor)) continue;
        for (int x = x0; x < x1; ++x) {
            const float* px = row + size_t(x) * 3;
            const float m = max3(px);
            if (m > floor) out.push_back({m, x, y, {px[0], px[1], px[2]}});
        }
        if (out.size() >= 2 * keep) floor = std::max(floor, keep_largest(out, keep));
    }
    return floor;
}
}  // namespace

void HotStream::add_row(int k, const float* row, float row_top) {
    std::vector<Entry>& f = found_[size_t(k)];
    // The band's floor, raised by the rows done so far: any row's keep_-th
    // largest value is one (keep_largest). Which rows have raised it when
    // this one starts changes how many candidates it keeps, never which are
    // hot.
    float floor = std::max(floor_, row_floor_.load(std::memory_order_relaxed));
    if (!(row_top > floor)) return;
    floor = hot_candidates(row, w_, floor, y0_ + k, keep_, f);
    // Only a row's keep_ largest can be among the keep_ largest of all
    // (`larger` is a strict total order): the rest need not wait for the
    // merge.
    if (f.size() < keep_) return;
    floor = std::max(floor, keep_largest(f, keep_));
    f.shrink_to_fit();
    float seen = row_floor_.load(std::memory_order_relaxed);
    while (seen < floor && !row_floor_.compare_exchange_weak(seen, floor, std::memory_order_relaxed)) {
    }
}

void HotStream::end_rows() {
    for (const std::vector<Entry>& f : found_)
        for (const Entry& e : f) {
            if (top_.size() < keep_) {
                top_.push_back(e);
                std::push_heap(top_.begin(), top_.end(), larger);  // front: the smallest kept
            } else if (larger(e, top_.front())) {
                std::pop_heap(top_.begin(), top_.end(), larger);
                top_.back() = e;
                std::push_heap(top_.begin(), top_.end(), larger);
            }
        }
    std::vector<std::vector<Entry>>().swap(found_);
}

HotSplit HotStream::finish(double relative_threshold, const HotRows& rows) {
    double mean = 0.0, total_power = 0.0;
    for (int y = 0; y < h_; ++y) {
        mean += rows.mean[y];
        total_power += rows.power[y];
    }
    mean /= 4.0 * kPi;
    double threshold = relative_threshold * mean;
    // split_hot's rule: the (max_hot + 1)-th largest value when more than
    // max_hot texels lie above the relative threshold (with max_hot <= 0 the
    // largest, when any does). The heap holds the keep_ largest values.
    if (top_.size() == keep_ && double(top_.front().m) > threshold) threshold = double(top_.front().m);
    HotSplit out;
    out.threshold = threshold;
    std::vector<Entry> hot;
    for (const Entry& e : top_)
        if (e.m > threshold) hot.push_back(e);
    std::sort(hot.begin(), hot.end(), [](const Entry& a, const Entry& b) { return a.y != b.y ? a.y < b.y : a.x < b.x; });
    make_hot_points(out, w_, h_, hot, total_power);
    return out;
}

}  // namespace iblbake
