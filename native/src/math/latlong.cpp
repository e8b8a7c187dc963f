#include "iblbake/math/latlong.h"

#include <algorithm>
#include <stdexcept>

namespace iblbake {

LonIntegrals lon_integrals(double u0, double u1) {
    // phi = (0.5 - u) 2 pi decreases with u: integrate over [phi(u1), phi(u0)].
    const double a = (0.5 - u1) * 2.0 * kPi, b = (0.5 - u0) * 2.0 * kPi;
    const double sa = std::sin(a), sb = std::sin(b), ca = std::cos(a), cb = std::cos(b);
    const double d = b - a;
    const double s2 = std::sin(2.0 * b) - std::sin(2.0 * a);
    return {d, sb - sa, ca - cb, 0.5 * d + 0.25 * s2, 0.5 * d - 0.25 * s2, 0.5 * (sb * sb - sa * sa)};
}

LatIntegrals lat_integrals(double v0, double v1) {
    // s = sin(lat), lat = (v - 0.5) pi.
    const double la = (v0 - 0.5) * kPi, lb = (v1 - 0.5) * kPi;
    const double sa = std::sin(la), sb = std::sin(lb), ca = std::cos(la), cb = std::cos(lb);
    // sin b - sin a without cancellation for thin rows.
    const double s0 = 2.0 * std::cos(0.5 * (la + lb)) * std::sin(0.5 * (lb - la));
    const double s1 = 0.5 * s0 * (sa + sb);
    const double s2 = s0 * (sa * sa + sa * sb + sb * sb) / 3.0;
    // integral sqrt(1 - s^2) ds = (s sqrt(1-s^2) + asin s) / 2 = (sin l cos l + l) / 2.
    const double c0 = 0.5 * ((sb * cb - sa * ca) + (lb - la));
    // integral s sqrt(1 - s^2) ds = -(1 - s^2)^1.5 / 3.
    const double c1 = (ca * ca * ca - cb * cb * cb) / 3.0;
    return {s0, s1, s2, c0, c1, s0 - s2};
}

Vec3d rect_moment(const LonIntegrals& lon, const LatIntegrals& lat) {
    // Engine w = (cos(lat) cos(phi), s, -cos(lat) sin(phi)).
    return {lon.pc * lat.c0, lon.p0 * lat.s1, -lon.ps * lat.c0};
}

std::vector<OverlayPiece> overlay_partitions(int n_a, int n_b) {
    std::vector<OverlayPiece> pieces;
    int a = 0, b = 0;
    double t = 0.0;
    while (a < n_a && b < n_b) {
        // Compare edges exactly in integers: (a+1)/n_a vs (b+1)/n_b.
        const long long ea = (long long)(a + 1) * n_b, eb = (long long)(b + 1) * n_a;
        const double end = ea <= eb ? double(a + 1) / n_a : double(b + 1) / n_b;
        pieces.push_back({a, b, t, end});
        t = end;
        if (ea <= eb) ++a;
        if (eb <= ea) ++b;
    }
    return pieces;
}

namespace {

// 4-point Gauss-Legendre on [-1, 1].
constexpr double kGlx[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526};
constexpr double kGlw[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538};

// The hats of `texels` centres cut by `bins` cells on [0, 1] (periodic or
// clamped), each piece integrated by `fn(x, hat, weight, w[6])` at Gauss
// points x in [0, 1] of the axis. With `want`, only the texels it marks:
// their pieces are those of the whole call, to the bit (the same stretches,
// integrated and merged in the same order).
template <typename Fn>
std::vector<HatPiece> hat_pieces(int texels, int bins, bool periodic, Fn&& fn, const std::vector<char>* want = nullptr) {
    // Breakpoints in integer units of 1 / (2 texels bins): centres (2k+1) bins, edges 2 texels b.
    const long long unit = 2LL * texels * bins;
    std::vector<long long> pts;
    for (int k = 0; k < texels; ++k) pts.push_back((2LL * k + 1) * bins);
    for (int b = 0; b <= bins; ++b) pts.push_back(2LL * texels * b);
    std::sort(pts.begin(), pts.end());
    pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
    std::vector<HatPiece> out;
    for (size_t k = 0; k + 1 < pts.size(); ++k) {
        const long long a = pts[k], e = pts[k + 1];
        const long long mid2 = a + e;  // twice the midpoint
        const int bin = int(std::min<long long>(bins - 1, mid2 / (2 * 2LL * texels)));
        // Left centre: the largest k with (2k+1) bins <= midpoint.
        const long long num = mid2 - 2LL * bins;  // 2 (mid - bins)
        const long long left = num < 0 ? -1 : num / (4LL * bins);
        int tl = int(left), tr = int(left + 1);
        if (periodic) {
            tl = (tl % texels + texels) % texels;
            tr = tr % texels;
        } else {
            tl = std::clamp(tl, 0, texels - 1);
            tr = std::clamp(tr, 0, texels - 1);
        }
        const bool want_l = !want || (*want)[size_t(tl)], want_r = !want || (*want)[size_t(tr)];
        if (!want_l && !want_r) continue;
        HatPiece pl{tl, bin, {0, 0, 0, 0, 0, 0}}, pr{tr, bin, {0, 0, 0, 0, 0, 0}};
        // Gauss points on sub-pieces of at most 1/64 of the axis (accuracy on wide bins).
        const double x0 = double(a) / unit, x1 = double(e) / unit;
        const int sub = std::max(1, int(std::ceil((x1 - x0) * 64.0)));
        for (int s = 0; s < sub; ++s) {
            const double s0 = x0 + (x1 - x0) * s / sub, s1 = x0 + (x1 - x0) * (s + 1) / sub;
            for (int g = 0; g < 4; ++g) {
                const double x = 0.5 * (s0 + s1) + 0.5 * (s1 - s0) * kGlx[g];
                const double wt = 0.5 * (s1 - s0) * kGlw[g];
                // Fraction toward the right centre (left + 1.5) / texels.
                const double f = std::clamp(x * texels - (double(left) + 0.5), 0.0, 1.0);
                fn(x, 1.0 - f, wt, pl.w);
                fn(x, f, wt, pr.w);
            }
        }
        if (want_l) out.push_back(pl);
        if (want_r) out.push_back(pr);
    }
    std::stable_sort(out.begin(), out.end(), [](const HatPiece& p, const HatPiece& q) {
        return p.bin != q.bin ? p.bin < q.bin : p.texel < q.texel;
    });
    std::vector<HatPiece> merged;
    for (const HatPiece& p : out) {
        if (!merged.empty() && merged.back().bin == p.bin && merged.back().texel == p.texel) {
            for (int k = 0; k < 6; ++k) merged.back().w[k] += p.w[k];
        } else {
            merged.push_back(p);
        }
    }
    return merged;
}

}  // namespace

namespace {

void lon_terms(double u, double hat, double wt, double w[6]) {
    const double phi = (0.5 - u) * 2.0 * kPi, c = std::cos(phi), s = std::sin(phi);
    const double m = hat * wt * 2.0 * kPi;  // dphi = 2 pi du
    w[0] += m, w[1] += m * c, w[2] += m * s, w[3] += m * c * c, w[4] += m * s * s, w[5] += m * s * c;
}

void lat_terms(double t, double hat, double wt, double w[6]) {
    const double lat = (0.5 - t) * kPi, s = std::sin(lat), c = std::cos(lat);
    const double m = hat * wt * kPi * c;  // ds = pi cos(lat) dt
    w[0] += m, w[1] += m * s, w[2] += m * s * s, w[3] += m * c, w[4] += m * s * c;
}

std::vector<char> wanted(int texels, const std::vector<int>& only) {
    std::vector<char> want(size_t(std::max(texels, 0)), 0);
    for (int t : only) {
        if (t < 0 || t >= texels) throw std::out_of_range("hat_pieces: a texel outside the axis");
        want[size_t(t)] = 1;
    }
    return want;
}

}  // namespace

std::vector<HatPiece> hat_pieces_lon(int texels, int bins) { return hat_pieces(texels, bins, true, lon_terms); }

std::vector<HatPiece> hat_pieces_lat(int texels, int bins) { return hat_pieces(texels, bins, false, lat_terms); }

std::vector<HatPiece> hat_pieces_lon(int texels, int bins, const std::vector<int>& only) {
    const std::vector<char> want = wanted(texels, only);
    return hat_pieces(texels, bins, true, lon_terms, &want);
}

std::vector<HatPiece> hat_pieces_lat(int texels, int bins, const std::vector<int>& only) {
    const std::vector<char> want = wanted(texels, only);
    return hat_pieces(texels, bins, false, lat_terms, &want);
}

}  // namespace iblbake
