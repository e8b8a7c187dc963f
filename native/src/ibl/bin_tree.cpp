#include "iblbake/ibl/bin_tree.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "iblbake/ibl/source.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/latlong.h"
#include "iblbake/util/parallel.h"

namespace iblbake {

namespace {

// Fills a BinLevel row by row from exact bins: radiance centroids, powers,
// covariances, radii.
class LevelFiller {
public:
    LevelFiller(BinLevel& level, int w, int h) : L_(level), w_(w), h_(h), cphi_(2 * w + 1), sphi_(2 * w + 1) {
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
    }

    void row(int y, const Bin* bins) const {
        const double v0 = 1.0 - double(y + 1) / h_, v1 = 1.0 - double(y) / h_;
        double clat[3], slat[3];
        for (int r = 0; r < 3; ++r) {
            const double lat = (v0 + (v1 - v0) * 0.5 * r - 0.5) * kPi;
            clat[r] = std::cos(lat);
            slat[r] = std::sin(lat);
        }
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
            nd.radius = float(std::acos(std::clamp(min_cos, -1.0, 1.0)));
        }
    }

private:
    BinLevel& L_;
    int w_, h_;
    std::vector<double> cphi_, sphi_;
};

BinLevel make_level(const std::vector<Bin>& bins, int w, int h) {
    BinLevel L;
    const LevelFiller fill(L, w, h);
    parallel_for(0, h, [&](int y) { fill.row(y, &bins[size_t(y) * w]); });
    return L;
}

}  // namespace

BinTree build_bin_tree(ImageView latlong, int finest_w, std::vector<Bin>* keep, int keep_w) {
    BinTree tree;
    int w = std::max(2, finest_w);
    int levels = 0;
    for (int v = w; v >= 2; v /= 2) ++levels;
    tree.levels.reserve(levels);  // the fillers below hold references into it
    std::vector<Bin> bins;
    if (w == 2) {
        bins = reduce_to_bins(latlong, 2, 1);
    } else {
        // The finest k levels straight from the reduction, 2^k level-0 rows
        // per task, coarsened on the way: only level k's exact bins are kept
        // (1/4^k of level 0's, which is never whole in memory).
        const int k = w >= 8 ? 2 : 1, block = 1 << k;
        const BinReduction red(latlong, w, w / 2);
        std::vector<LevelFiller> fillers;
        for (int l = 0; l < k; ++l) {
            tree.levels.emplace_back();
            fillers.emplace_back(tree.levels.back(), w >> l, (w >> l) / 2);
        }
        const int kw = w >> k, kh = kw / 2;
        bins.assign(size_t(kw) * kh, Bin{});
        parallel_for(0, kh, [&](int y) {
            thread_local std::vector<Bin> cur, next;
            cur.resize(size_t(block) * w);
            for (int r = 0; r < block; ++r) red.row(y * block + r, &cur[size_t(r) * w]);
            int cw = w, rows = block;
            for (int l = 0; l < k; ++l) {
                for (int r = 0; r < rows; ++r) fillers[l].row((y * block >> l) + r, &cur[size_t(r) * cw]);
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
        });
        w = kw;
    }
    while (true) {
        if (keep && w == keep_w) *keep = bins;
        tree.levels.push_back(make_level(bins, w, w / 2));
        if (w <= 2) break;
        bins = coarsen_bins(bins, w, w / 2);
        w /= 2;
    }
    return tree;
}

}  // namespace iblbake
