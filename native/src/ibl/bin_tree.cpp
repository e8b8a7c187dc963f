#include "iblbake/ibl/bin_tree.h"

#include <algorithm>
#include <cmath>

#include "iblbake/ibl/parallel.h"
#include "iblbake/ibl/source.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/latlong.h"

namespace iblbake {

namespace {

BinLevel make_level(const std::vector<Bin>& bins, int w, int h) {
    BinLevel L;
    L.w = w;
    L.h = h;
    const size_t n = size_t(w) * h;
    for (auto* v : {&L.px, &L.py, &L.pz, &L.cx, &L.cy, &L.cz, &L.omega, &L.radius}) v->resize(n);
    for (auto& v : L.power) v.resize(n);
    // Longitudes at every half bin (the radius test's 3 x 3 points per bin):
    // cos and sin once per level, not per bin.
    std::vector<double> cphi(2 * w + 1), sphi(2 * w + 1);
    for (int k = 0; k <= 2 * w; ++k) {
        const double phi = (0.5 - 0.5 * k / w) * 2.0 * kPi;
        cphi[k] = std::cos(phi);
        sphi[k] = std::sin(phi);
    }
    parallel_for(0, h, [&](int y) {
        const double v0 = 1.0 - double(y + 1) / h, v1 = 1.0 - double(y) / h;
        double clat[3], slat[3];
        for (int r = 0; r < 3; ++r) {
            const double lat = (v0 + (v1 - v0) * 0.5 * r - 0.5) * kPi;
            clat[r] = std::cos(lat);
            slat[r] = std::sin(lat);
        }
        for (int x = 0; x < w; ++x) {
            const size_t i = L.index(x, y);
            const Bin& b = bins[i];
            Vec3d c{b.moment[0], b.moment[1], b.moment[2]};
            const double cl = length(c);
            c = cl > 0.0 ? c / cl : blender_to_engine(latlong_to_direction((x + 0.5) / w, 0.5 * (v0 + v1)));
            Vec3d p{0, 0, 0};
            for (int ch = 0; ch < 3; ++ch) p += Vec3d{b.vector[ch][0], b.vector[ch][1], b.vector[ch][2]};
            const double pl = length(p);
            p = pl > 0.0 ? p / pl : c;
            L.cx[i] = float(c.x); L.cy[i] = float(c.y); L.cz[i] = float(c.z);
            L.px[i] = float(p.x); L.py[i] = float(p.y); L.pz[i] = float(p.z);
            // Weights shrunk by |first moment| / zeroth moment: a bin used at its
            // (unit) centroid then integrates any kernel linear in n.w exactly,
            // where Omega alone would overweight a wide bin by about radius^2 / 6.
            const double psum = b.power[0] + b.power[1] + b.power[2];
            const double pshrink = psum > 0.0 ? pl / psum : 1.0;
            for (int ch = 0; ch < 3; ++ch) L.power[ch][i] = float(b.power[ch] * pshrink);
            L.omega[i] = float(cl);
            double min_cos = 1.0;
            for (int k = 0; k < 9; ++k) {
                const int col = 2 * x + k % 3, r = k / 3;
                const Vec3d blender{clat[r] * cphi[col], clat[r] * sphi[col], slat[r]};
                min_cos = std::min(min_cos, dot(c, blender_to_engine(blender)));
            }
            L.radius[i] = float(std::acos(std::clamp(min_cos, -1.0, 1.0)));
        }
    });
    return L;
}

}  // namespace

BinTree build_bin_tree(ImageView latlong, int finest_w) {
    BinTree tree;
    int w = std::max(2, finest_w);
    std::vector<Bin> bins = reduce_to_bins(latlong, w, w / 2);
    while (true) {
        tree.levels.push_back(make_level(bins, w, w / 2));
        if (w <= 2) break;
        bins = coarsen_bins(bins, w, w / 2);
        w /= 2;
    }
    return tree;
}

}  // namespace iblbake
