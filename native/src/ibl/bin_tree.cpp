#include "iblbake/ibl/bin_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>

#include "iblbake/ibl/source.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/fast_math.h"
#include "iblbake/math/latlong.h"
#include "iblbake/util/parallel.h"

namespace iblbake {

void colour_weight_scales(const double* channel_mean, double* a_scale) {
    for (int c = 0; c < 3; ++c) a_scale[c] = channel_mean[c] > 0.0 ? 20.0 / channel_mean[c] : 0.0;
}

// Whether max_c a_c s_c > tol, without a division or a root (every bin
// is tested, few pass): with P, V the sums of the channels' powers and
// first moments, u = P_c P, X = |V_c P - V P_c|^2 = |d|^2 u^2 and
// Y = ||V|^2 P_c^2 - |V_c|^2 P^2| (the traces' difference times u^2),
// a_c s_c u^2 = a_c (sqrt(X) u / beta + (X + Y) / (2 beta^2)).
bool bin_colour_varies(const Bin& b, double beta, double inv_omega, const double* a_scale, double tol) {
    beta = std::max(beta, 1e-9);
    const double ib2 = 1.0 / (beta * beta);
    const double P = b.power[0] + b.power[1] + b.power[2];
    const double Vx = b.vector[0][0] + b.vector[1][0] + b.vector[2][0];
    const double Vy = b.vector[0][1] + b.vector[1][1] + b.vector[2][1];
    const double Vz = b.vector[0][2] + b.vector[1][2] + b.vector[2][2];
    const double vv = Vx * Vx + Vy * Vy + Vz * Vz;
    bool varies = false;
    for (int c = 0; c < 3; ++c) {
        const double pc = b.power[c];
        const double a = pc > 0.0 ? std::min(1.0, a_scale[c] * pc * inv_omega) : 0.0;  // a_c
        const double* vc = b.vector[c];
        const double u = pc * P;
        const double dx = vc[0] * P - Vx * pc, dy = vc[1] * P - Vy * pc, dz = vc[2] * P - Vz * pc;
        const double X = dx * dx + dy * dy + dz * dz;
        const double Y = std::fabs(vv * pc * pc - (vc[0] * vc[0] + vc[1] * vc[1] + vc[2] * vc[2]) * P * P);
        const double R = tol * u * u - 0.5 * a * (X + Y) * ib2;  // a_c sqrt(X) u / beta > R ?
        varies |= (a > 0.0) & ((R < 0.0) | (a * a * X * u * u * ib2 > R * R));
    }
    return varies;
}

// Out of line, so that the loops that call it stay lean.
#if defined(__GNUC__)
__attribute__((noinline))
#endif
uint32_t bin_channel_moments(const Bin& b, double beta, ChromaBin& out) {
    beta = std::max(beta, 1e-9);
    const double ib = 1.0 / beta, ib2 = 0.5 * ib * ib;
    const double psum = b.power[0] + b.power[1] + b.power[2];
    Vec3d m{0, 0, 0};
    for (int c = 0; c < 3; ++c) m += Vec3d{b.vector[c][0], b.vector[c][1], b.vector[c][2]};
    m = m / psum;
    const double mm = dot(m, m), trace = 1.0 - mm;
    uint32_t scores = 0;
    for (int c = 0; c < 3; ++c) {
        const double pc = b.power[c];
        const Vec3d vc{b.vector[c][0], b.vector[c][1], b.vector[c][2]};
        const double vl = length(vc);
        ChromaChannel& ch = out.channel[c];
        ch = ChromaChannel{0, 0, 1, 0, 1};
        if (!(pc > 0.0) || !(vl > 0.0)) continue;  // no power: adds nothing
        const Vec3d mc = vc / pc, p = vc / vl, dv = mc - m;
        const double mcc = dot(mc, mc), d2 = dot(dv, dv);
        const double score = std::min(1.0, std::sqrt(d2) * ib + (std::fabs(mm - mcc) + d2) * ib2);
        scores |= uint32_t(std::ceil(score * 1023.0)) << (10 * c);
        ch.px = float(p.x), ch.py = float(p.y), ch.pz = float(p.z);
        ch.g = float(std::max(0.0, 1.0 - vl / pc));
        ch.cov_scale = trace > 0.0 ? float((1.0 - mcc) / trace) : 1.0f;
    }
    return scores;
}

namespace {

// bin_colour_varies (above) for eight bins, a lane each: the same
// operations in the same order in every lane, built for AVX-512, AVX2 and
// baseline x86-64 without fused multiply-add, so each lane's answer is the
// scalar test's. Bit l of the result: bins[l] varies. (beta[l]: bins[l]'s
// radius; a_scale: a_c = min(1, a_scale[c] P_c inv_omega).)
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default"), optimize("fp-contract=off")))
#endif
unsigned colour_varies8(const Bin* bins, const double* beta_in, double inv_omega, const double* a_scale, double tol) {
    typedef double V8d __attribute__((vector_size(64)));
    typedef long long V8l __attribute__((vector_size(64)));
    V8d beta, pw[3], vec[3][3];
    for (int l = 0; l < 8; ++l) {
        beta[l] = beta_in[l];
        for (int c = 0; c < 3; ++c) {
            pw[c][l] = bins[l].power[c];
            for (int k = 0; k < 3; ++k) vec[c][k][l] = bins[l].vector[c][k];
        }
    }
    const V8d zero = V8d{} + 0.0, one = zero + 1.0;
    beta = beta < 1e-9 ? zero + 1e-9 : beta;  // std::max(beta, 1e-9)
    const V8d ib2 = one / (beta * beta);
    const V8d P = pw[0] + pw[1] + pw[2];
    const V8d Vx = vec[0][0] + vec[1][0] + vec[2][0];
    const V8d Vy = vec[0][1] + vec[1][1] + vec[2][1];
    const V8d Vz = vec[0][2] + vec[1][2] + vec[2][2];
    const V8d vv = Vx * Vx + Vy * Vy + Vz * Vz;
    V8l varies = V8l{} + 0;
    for (int c = 0; c < 3; ++c) {
        const V8d pc = pw[c];
        const V8d t = a_scale[c] * pc * inv_omega;
        const V8d a = pc > 0.0 ? (t < 1.0 ? t : one) : zero;  // std::min(1.0, t), 0 without power
        const V8d* vc = vec[c];
        const V8d u = pc * P;
        const V8d dx = vc[0] * P - Vx * pc, dy = vc[1] * P - Vy * pc, dz = vc[2] * P - Vz * pc;
        const V8d X = dx * dx + dy * dy + dz * dz;
        const V8d y = vv * pc * pc - (vc[0] * vc[0] + vc[1] * vc[1] + vc[2] * vc[2]) * P * P;
        const V8d Y = (V8d)((V8l)y & (V8l{} + 0x7fffffffffffffffLL));  // fabs
        const V8d R = tol * u * u - 0.5 * a * (X + Y) * ib2;
        varies |= (a > 0.0) & ((R < 0.0) | (a * a * X * u * u * ib2 > R * R));
    }
    unsigned out = 0;
    for (int l = 0; l < 8; ++l) out |= unsigned(varies[l] != 0) << l;
    return out;
}

// bin_channel_moments (above) for eight bins of varying colour,
// a lane each (b[l], beta[l] its radius, out[l]): the same operations in the
// same order in every lane (plain lanes the compiler vectorises; sqrt and
// division are exact in every instruction set), built without fused
// multiply-add, so every lane's scores and moments are the scalar ones.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default"), optimize("fp-contract=off", "no-math-errno")))
#endif
void channel_moments8(const Bin* const* b, const double* beta_in, ChromaBin* const* out, uint32_t* scores) {
    constexpr int L = 8;
    double ib[L], ib2[L], mx[L], my[L], mz[L], mm[L], trace[L];
    for (int l = 0; l < L; ++l) {
        const double beta = beta_in[l] < 1e-9 ? 1e-9 : beta_in[l];  // std::max(beta, 1e-9)
        ib[l] = 1.0 / beta;
        ib2[l] = 0.5 * ib[l] * ib[l];
        const Bin& bl = *b[l];
        const double psum = bl.power[0] + bl.power[1] + bl.power[2];
        mx[l] = ((0.0 + bl.vector[0][0]) + bl.vector[1][0]) + bl.vector[2][0];
        my[l] = ((0.0 + bl.vector[0][1]) + bl.vector[1][1]) + bl.vector[2][1];
        mz[l] = ((0.0 + bl.vector[0][2]) + bl.vector[1][2]) + bl.vector[2][2];
        mx[l] = mx[l] / psum, my[l] = my[l] / psum, mz[l] = mz[l] / psum;
        mm[l] = mx[l] * mx[l] + my[l] * my[l] + mz[l] * mz[l];
        trace[l] = 1.0 - mm[l];
        scores[l] = 0;
    }
    for (int c = 0; c < 3; ++c) {
        double pc[L], vx[L], vy[L], vz[L];
        for (int l = 0; l < L; ++l) {
            pc[l] = b[l]->power[c];
            vx[l] = b[l]->vector[c][0], vy[l] = b[l]->vector[c][1], vz[l] = b[l]->vector[c][2];
        }
        double vl[L], px[L], py[L], pz[L], mcc[L], score[L], g[L], cs[L];
        for (int l = 0; l < L; ++l) {
            vl[l] = std::sqrt(vx[l] * vx[l] + vy[l] * vy[l] + vz[l] * vz[l]);
            const double mcx = vx[l] / pc[l], mcy = vy[l] / pc[l], mcz = vz[l] / pc[l];
            px[l] = vx[l] / vl[l], py[l] = vy[l] / vl[l], pz[l] = vz[l] / vl[l];
            const double dx = mcx - mx[l], dy = mcy - my[l], dz = mcz - mz[l];
            mcc[l] = mcx * mcx + mcy * mcy + mcz * mcz;
            const double d2 = dx * dx + dy * dy + dz * dz;
            const double s = std::sqrt(d2) * ib[l] + (std::fabs(mm[l] - mcc[l]) + d2) * ib2[l];
            score[l] = (s < 1.0 ? s : 1.0) * 1023.0;  // std::min(1.0, s)
            const double t = 1.0 - vl[l] / pc[l];
            g[l] = 0.0 < t ? t : 0.0;  // std::max(0.0, t)
            cs[l] = (1.0 - mcc[l]) / trace[l];
        }
        for (int l = 0; l < L; ++l) {
            ChromaChannel& ch = out[l]->channel[c];
            ch = ChromaChannel{0, 0, 1, 0, 1};
            if (!(pc[l] > 0.0) || !(vl[l] > 0.0)) continue;  // no power: adds nothing
            scores[l] |= uint32_t(std::ceil(score[l])) << (10 * c);
            ch.px = float(px[l]), ch.py = float(py[l]), ch.pz = float(pz[l]);
            ch.g = float(g[l]);
            ch.cov_scale = trace[l] > 0.0 ? float(cs[l]) : 1.0f;
        }
    }
}

// Fills a BinLevel row by row from exact bins: radiance centroids, powers,
// covariances, radii; and the per-channel moments of the bins of varying
// colour (kept per row until finish() numbers them).
class LevelFiller {
public:
    // chroma: the level's rows of BinTree::chroma, the first at row index first_row.
    LevelFiller(BinLevel& level, int w, int h, const double* channel_mean, double chroma_tolerance,
                std::vector<ChromaBin>* chroma, uint32_t first_row)
        : L_(level), w_(w), h_(h), cphi_(2 * w + 1), sphi_(2 * w + 1), chroma_(chroma), first_row_(first_row),
          tol_(chroma_tolerance) {
        L_.w = w;
        L_.h = h;
        L_.nodes.resize(size_t(w) * h);  // not zeroed here: row() writes every node whole
        // Longitudes at every half bin (the radius test's 3 x 3 points per
        // bin): cos and sin once per level, not per bin.
        for (int k = 0; k <= 2 * w; ++k) {
            const double phi = (0.5 - 0.5 * k / w) * 2.0 * kPi;
            cphi_[k] = std::cos(phi);
            sphi_[k] = std::sin(phi);
        }
        // a_c = min(1, 20 P_c / (Omega mean_c)) = min(1, a_scale_[c] P_c / Omega).
        colour_weight_scales(channel_mean, a_scale_);
    }

    void row(int y, const Bin* bins) const {
        const double v0 = 1.0 - double(y + 1) / h_, v1 = 1.0 - double(y) / h_;
        double clat[3], slat[3];
        for (int r = 0; r < 3; ++r) {
            const double lat = (v0 + (v1 - v0) * 0.5 * r - 0.5) * kPi;
            clat[r] = std::cos(lat);
            slat[r] = std::sin(lat);
        }
        const double inv_omega = w_ / (2.0 * kPi * (slat[2] - slat[0]));  // every bin of the row
        for (int x = 0; x < w_; ++x) {
            BinNode& nd = L_.nodes[L_.index(x, y)];
            nd = BinNode{};
            const Bin& b = bins[x];
            const double psum = b.power[0] + b.power[1] + b.power[2];
            Vec3d m{0, 0, 0};
            for (int ch = 0; ch < 3; ++ch) m += Vec3d{b.vector[ch][0], b.vector[ch][1], b.vector[ch][2]};
            const double ml = length(m);
            for (int ch = 0; ch < 3; ++ch) nd.power[ch] = float(b.power[ch]);
            if (!(psum > 0.0) || !(ml > 0.0)) {  // no radiance: never used
                nd.radius = -1.0f;
                continue;
            }
            m = m / psum;  // |m| <= 1
            const Vec3d p = m / (ml / psum);
            nd.px = float(p.x), nd.py = float(p.y), nd.pz = float(p.z);
            nd.g = float(std::max(0.0, 1.0 - ml / psum));
            const double* s = b.second;
            const double cov[6] = {s[0] / psum - m.x * m.x, s[1] / psum - m.y * m.y, s[2] / psum - m.z * m.z,
                                   s[3] / psum - m.x * m.y, s[4] / psum - m.x * m.z, s[5] / psum - m.y * m.z};
            for (int k = 0; k < 6; ++k) nd.cov[k] = float(cov[k]);
            double min_cos = 1.0;
            for (int k = 0; k < 9; ++k) {
                const int col = 2 * x + k % 3, r = k / 3;
                const Vec3d blender{clat[r] * cphi_[col], clat[r] * sphi_[col], slat[r]};
                min_cos = std::min(min_cos, dot(p, blender_to_engine(blender)));
            }
            nd.radius = acos_float(std::clamp(min_cos, -1.0, 1.0));  // float(std::acos()), cheaper
        }
        // Issue 25's test of every bin (bin_tree.h), apart from the loop above;
        // the row's bins of varying colour counted first, then stored.
        thread_local std::vector<int> varies;
        varies.clear();
        int x0 = 0;
        for (; x0 + 8 <= w_; x0 += 8) {  // eight at a time (colour_varies8), the same answers
            double beta[8];
            unsigned live = 0;
            for (int l = 0; l < 8; ++l) {
                const float radius = L_.nodes[L_.index(x0 + l, y)].radius;
                beta[l] = radius;
                live |= unsigned(radius >= 0.0f) << l;
            }
            const unsigned v = live & colour_varies8(bins + x0, beta, inv_omega, a_scale_, tol_);
            for (int l = 0; l < 8; ++l)
                if (v >> l & 1u) varies.push_back(x0 + l);
        }
        for (int x = x0; x < w_; ++x) {
            const float radius = L_.nodes[L_.index(x, y)].radius;
            if (radius >= 0.0f && bin_colour_varies(bins[x], radius, inv_omega, a_scale_, tol_)) varies.push_back(x);
        }
        std::vector<ChromaBin>& row = chroma_[y];
        row.assign(varies.size(), ChromaBin{});
        size_t k = 0;
        for (; k + 8 <= varies.size(); k += 8) {  // eight at a time (channel_moments8), the same results
            const Bin* b8[8];
            double beta[8];
            ChromaBin* out[8];
            uint32_t scores[8];
            for (int l = 0; l < 8; ++l) {
                b8[l] = &bins[varies[k + l]];
                beta[l] = L_.nodes[L_.index(varies[k + l], y)].radius;
                out[l] = &row[k + l];
            }
            channel_moments8(b8, beta, out, scores);
            for (int l = 0; l < 8; ++l) {
                BinNode& nd = L_.nodes[L_.index(varies[k + l], y)];
                nd.chroma = (first_row_ + uint32_t(y) + 1) << 12 | uint32_t(k + l);
                nd.chroma_scores = scores[l];
            }
        }
        for (; k < varies.size(); ++k) {
            BinNode& nd = L_.nodes[L_.index(varies[k], y)];
            nd.chroma = (first_row_ + uint32_t(y) + 1) << 12 | uint32_t(k);
            nd.chroma_scores = bin_channel_moments(bins[varies[k]], nd.radius, row[k]);
        }
    }

private:
    BinLevel& L_;
    int w_, h_;
    std::vector<double> cphi_, sphi_;
    std::vector<ChromaBin>* chroma_;  // row y's written by row(y) alone
    uint32_t first_row_;
    double a_scale_[3];
    double tol_;
};

// Mean radiance per channel (texel-constant radiance, exact solid angles).
void channel_mean(ImageView img, double* mean) {
    std::vector<double> rows(size_t(3) * img.height, 0.0);
    parallel_for(0, img.height, [&](int y) {
        const double lat0 = (0.5 - double(y + 1) / img.height) * kPi, lat1 = (0.5 - double(y) / img.height) * kPi;
        const double om = 2.0 * kPi / img.width * (std::sin(lat1) - std::sin(lat0));
        const float* px = img.at(0, y);
        for (int x = 0; x < img.width; ++x)
            for (int c = 0; c < 3; ++c) rows[size_t(3) * y + c] += px[3 * x + c];
        for (int c = 0; c < 3; ++c) rows[size_t(3) * y + c] *= om;
    });
    for (int c = 0; c < 3; ++c) mean[c] = 0.0;
    for (int y = 0; y < img.height; ++y)
        for (int c = 0; c < 3; ++c) mean[c] += rows[size_t(3) * y + c] / (4.0 * kPi);
}

}  // namespace

namespace {

// The tree from level 0's exact bins, bin row by bin row: row(br, out)
// writes bins (0..w-1, br) of the w x w/2 grid (w >= 2, a power of two).
// The means are given (options.channel_mean, or computed by the caller).
// With level0_done, level 0's rows are made in order and level0_done(br)
// is called (br increasing) once every row below br is made.
template <typename RowFn>
BinTree build_from_rows(int finest_w, const RowFn& level0_row, const double* channel_means, std::vector<Bin>* keep,
                        int keep_w, const BinTreeOptions& options,
                        const std::function<void(int)>& level0_done = {}) {
    BinTree tree;
    std::copy(channel_means, channel_means + 3, tree.channel_mean);
    const double* mean = tree.channel_mean;
    const double tol = options.chroma_tolerance;
    int w = std::max(2, finest_w);
    int levels = 0;
    for (int v = w; v >= 2; v /= 2) ++levels;
    tree.levels.reserve(levels);  // the fillers below hold references into it
    std::vector<Bin> bins;
    std::vector<std::unique_ptr<LevelFiller>> fillers;
    // Every level's rows of bins of varying colour, level 0's first.
    size_t rows = 0;
    for (int v = w; v >= 2; v /= 2) rows += size_t(v / 2);
    tree.chroma.resize(rows);
    uint32_t first_row = 0;
    auto add_level = [&](int lw) {
        tree.levels.emplace_back();
        fillers.push_back(std::make_unique<LevelFiller>(tree.levels.back(), lw, lw / 2, mean, tol,
                                                        tree.chroma.data() + first_row, first_row));
        first_row += uint32_t(lw / 2);
        return fillers.back().get();
    };
    if (w == 2) {
        bins.assign(2, Bin{});
        level0_row(0, bins.data());
    } else {
        // The finest k levels straight from the reduction, 2^k level-0 rows
        // per task, coarsened on the way: only level k's exact bins are kept
        // (1/4^k of level 0's, which is never whole in memory).
        const int k = w >= 8 ? 2 : 1, block = 1 << k;
        LevelFiller* fine[2];
        for (int l = 0; l < k; ++l) fine[l] = add_level(w >> l);
        const int kw = w >> k, kh = kw / 2;
        bins.assign(size_t(kw) * kh, Bin{});
        auto task = [&](int y) {
            thread_local std::vector<Bin> cur, next;
            cur.resize(size_t(block) * w);
            for (int r = 0; r < block; ++r) level0_row(y * block + r, &cur[size_t(r) * w]);
            int cw = w, rows = block;
            for (int l = 0; l < k; ++l) {
                for (int r = 0; r < rows; ++r) fine[l]->row((y * block >> l) + r, &cur[size_t(r) * cw]);
                next.assign(size_t(rows / 2) * (cw / 2), Bin{});
                for (int r = 0; r < rows / 2; ++r)
                    for (int x = 0; x < cw / 2; ++x)
                        for (int dy = 0; dy < 2; ++dy)
                            for (int dx = 0; dx < 2; ++dx)
                                add_bins(next[size_t(r) * (cw / 2) + x], cur[size_t(2 * r + dy) * cw + 2 * x + dx]);
                std::swap(cur, next);
                cw /= 2;
                rows /= 2;
            }
            std::copy(cur.begin(), cur.begin() + kw, bins.begin() + size_t(y) * kw);
        };
        if (level0_done) parallel_for_ordered(0, kh, task, [&](int y) { level0_done(y * block); });
        else parallel_for(0, kh, task);
        w = kw;
    }
    while (true) {
        const LevelFiller* fill = add_level(w);
        parallel_for(0, w / 2, [&](int y) { fill->row(y, &bins[size_t(y) * w]); });
        // The kept bins are moved out once coarsened (not copied beside them).
        std::vector<Bin> coarser;
        if (w > 2) coarser = coarsen_bins(bins, w, w / 2);
        if (keep && w == keep_w) *keep = std::move(bins);
        if (w <= 2) break;
        bins = std::move(coarser);
        w /= 2;
    }
    return tree;
}

}  // namespace

BinTree build_bin_tree(ImageView latlong, int finest_w, std::vector<Bin>* keep, int keep_w,
                       const BinTreeOptions& options) {
    double mean[3];
    if (options.channel_mean) std::copy(options.channel_mean, options.channel_mean + 3, mean);
    else channel_mean(latlong, mean);
    const int w = std::max(2, finest_w);
    const BinReduction red(latlong, w, w / 2, options.sh9 != nullptr);  // reduce_to_bins(latlong, 2, 1)'s own, at w = 2
    std::function<void(int)> level0_done;
    std::vector<int> first;  // the first source row that level 0's rows from br on read
    if (options.source_done) {
        first.assign(size_t(w / 2) + 1, latlong.height);
        for (int br = w / 2 - 1; br >= 0; --br)
            first[size_t(br)] = std::min(first[size_t(br) + 1], red.source_rows(br).first);
        level0_done = [&](int br) { options.source_done(first[size_t(br)]); };
    }
    std::vector<std::array<Sh9, 3>> sh9_rows(options.sh9 ? size_t(w / 2) : 0);
    BinTree tree = build_from_rows(
        w, [&](int br, Bin* out) { red.row(br, out, options.sh9 ? &sh9_rows[size_t(br)] : nullptr); }, mean, keep,
        keep_w, options, level0_done);
    if (options.source_done) options.source_done(latlong.height);  // (at w = 2 the only call)
    if (options.sh9) *options.sh9 = sum_sh9_rows(sh9_rows);
    return tree;
}

BinRowStream::BinRowStream(int img_w, int img_h, int finest_w, bool sh9)
    : w_(std::max(2, finest_w)), img_h_(img_h), red_(ImageView(nullptr, img_w, img_h), w_, w_ / 2, sh9),
      bins_(size_t(w_) * (w_ / 2)), sh9_rows_(sh9 ? size_t(w_ / 2) : 0), done_(w_ / 2, 0) {}

void BinRowStream::add_rows(ImageView img, int y0, int y1) {
    // Bin rows whose every source row is among y0..y1, not yet reduced.
    std::vector<int> ready;
    for (int br = 0; br < w_ / 2; ++br) {
        if (done_[br]) continue;
        const auto [first, last] = red_.source_rows(br);
        if (first >= y0 && last <= y1) ready.push_back(br);
    }
    parallel_for(0, int(ready.size()), [&](int k) {
        const int br = ready[k];
        red_.row(img, br, &bins_[size_t(br) * w_], sh9_rows_.empty() ? nullptr : &sh9_rows_[size_t(br)]);
        done_[br] = 1;
    });
}

int BinRowStream::reach(int img_h, int finest_w) {
    const int w = std::max(2, finest_w);
    std::vector<int> first(size_t(w / 2), std::numeric_limits<int>::max()), last(size_t(w / 2), -1);
    for (const HatPiece& p : hat_pieces_lat(img_h, w / 2)) {
        first[size_t(p.bin)] = std::min(first[size_t(p.bin)], p.texel);
        last[size_t(p.bin)] = std::max(last[size_t(p.bin)], p.texel);
    }
    int r = 1;
    for (int br = 0; br < w / 2; ++br)
        if (last[size_t(br)] >= first[size_t(br)]) r = std::max(r, last[size_t(br)] - first[size_t(br)] + 1);
    return r;
}

int BinRowStream::max_reach() const { return reach(img_h_, w_); }

int BinRowStream::pending() const {
    int n = 0;
    for (char d : done_) n += !d;
    return n;
}

std::pair<int, int> BinRowStream::source_rows(int br) const { return red_.source_rows(br); }

std::array<Sh9, 3> BinRowStream::sh9() const {
    if (pending() != 0) throw std::logic_error("BinRowStream::sh9: bin rows whose source rows never came");
    if (sh9_rows_.empty()) throw std::logic_error("BinRowStream::sh9: a stream made without SH9");
    return sum_sh9_rows(sh9_rows_);
}

std::vector<Bin> BinRowStream::take_bins() {
    if (pending() != 0) throw std::logic_error("BinRowStream::take_bins: bin rows whose source rows never came");
    return std::move(bins_);
}

BinTree BinRowStream::finish(const double* channel_means, std::vector<Bin>* keep, int keep_w,
                             const BinTreeOptions& options) {
    if (pending() != 0) throw std::logic_error("BinRowStream::finish: bin rows whose source rows never came");
    BinTree tree = build_from_rows(
        w_, [this](int br, Bin* out) { std::copy_n(&bins_[size_t(br) * w_], w_, out); }, channel_means, keep, keep_w,
        options);
    std::vector<Bin>().swap(bins_);
    return tree;
}

}  // namespace iblbake
