#include "iblbake/math/latlong.h"

#include <algorithm>

#include "iblbake/math/sh.h"

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

Sh9 sh9_rect_integral(const LonIntegrals& lon, const LatIntegrals& lat) {
    // x = c cos(phi), y = s, z = -c sin(phi), c = sqrt(1 - s^2).
    return {0.282095 * lon.p0 * lat.s0,
            0.488603 * lon.p0 * lat.s1,
            0.488603 * -lon.ps * lat.c0,
            0.488603 * lon.pc * lat.c0,
            1.092548 * lon.pc * lat.c1,
            1.092548 * -lon.ps * lat.c1,
            0.315392 * (3.0 * lon.pss * lat.q - lon.p0 * lat.s0),
            1.092548 * -lon.psc * lat.q,
            0.546274 * (lon.pcc * lat.q - lon.p0 * lat.s2)};
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

}  // namespace iblbake
