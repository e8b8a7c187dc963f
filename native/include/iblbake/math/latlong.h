// Latitude-longitude mapping of SPEC.md section 1 (Blender world space, +Z up).
#pragma once
#include <cmath>
#include <vector>

#include "iblbake/math/vec3.h"

namespace iblbake {

// u in [0, 1] left to right, v in [0, 1] bottom (nadir) to top (zenith).
struct LatLongUV { double u, v; };

inline LatLongUV direction_to_latlong(const Vec3d& d) {
    const double u = 0.5 - std::atan2(d.y, d.x) / (2.0 * kPi);
    const double zc = std::fmax(-1.0, std::fmin(1.0, d.z / length(d)));
    return {u - std::floor(u), 0.5 + std::asin(zc) / kPi};
}

inline Vec3d latlong_to_direction(double u, double v) {
    const double phi = (0.5 - u) * 2.0 * kPi;
    const double lat = (v - 0.5) * kPi;
    const double c = std::cos(lat);
    return {c * std::cos(phi), c * std::sin(phi), std::sin(lat)};
}

// Centre of texel (col, row), row 0 at the top of the file.
inline Vec3d latlong_texel_direction(int col, int row, int w, int h) {
    return latlong_to_direction((col + 0.5) / w, 1.0 - (row + 0.5) / h);
}

// Exact solid angle of any texel of row `row`: (2 pi / W) (sin lat_top - sin lat_bottom).
inline double latlong_row_solid_angle(int row, int w, int h) {
    const double top = 0.5 * kPi - kPi * row / h;
    const double bottom = 0.5 * kPi - kPi * (row + 1) / h;
    // sin a - sin b = 2 cos((a+b)/2) sin((a-b)/2): no cancellation near the poles.
    return (2.0 * kPi / w) * 2.0 * std::cos(0.5 * (top + bottom)) * std::sin(0.5 * (top - bottom));
}

}  // namespace iblbake

namespace iblbake {

// Exact integrals over a lat-long rectangle u in [u0, u1], v in [v0, v1]
// (SPEC.md section 1) with dOmega = dphi ds, s = sin(latitude). They make
// per-texel moments exact for a texel-constant radiance: the vector moment
// (integral of w dOmega) and the SH projection. Each factorises into a
// longitude part and a latitude part.
struct LonIntegrals {  // over phi: 1, cos, sin, cos^2, sin^2, sin cos
    double p0, pc, ps, pcc, pss, psc;
};
struct LatIntegrals {  // over s: 1, s, s^2, sqrt(1-s^2), s sqrt(1-s^2), 1-s^2
    double s0, s1, s2, c0, c1, q;
};
LonIntegrals lon_integrals(double u0, double u1);
LatIntegrals lat_integrals(double v0, double v1);

// Engine-space vector moment: integral of w dOmega over the rectangle.
Vec3d rect_moment(const LonIntegrals& lon, const LatIntegrals& lat);
// Solid angle of the rectangle.
inline double rect_solid_angle(const LonIntegrals& lon, const LatIntegrals& lat) { return lon.p0 * lat.s0; }

// Overlay of two partitions of [0, 1] into n_a and n_b equal cells: the
// pieces (a cell of each) in order, with their extents.
struct OverlayPiece {
    int a, b;
    double t0, t1;
};
std::vector<OverlayPiece> overlay_partitions(int n_a, int n_b);

// SPEC.md section 1's bilinear L is a sum of texel values times hats:
// L(u, v) = sum L_xy H_x(u) H_y(t), t = 1 - v, with H_x the periodic hat of
// column x (1 at its centre, 0 at its neighbours') and H_y that of row y
// (the top and bottom rows' hats flat out to the pole). Every integral of L
// over a lat-long rectangle against a function of longitude times a function
// of latitude is then a sum of products of one-dimensional hat integrals.
// A HatPiece is one texel's hat restricted to one bin of a grid of `bins`
// equal cells, integrated against a set of functions (Gauss-Legendre on each
// piece between breakpoints: exact to double rounding):
//   longitude: over phi of H_x * {1, cos, sin, cos^2, sin^2, sin cos}
//   latitude:  over s = sin(lat) of H_y * {1, s, s^2, sqrt(1 - s^2), s sqrt(1 - s^2)}
// (the measures of LonIntegrals and LatIntegrals). Sorted by bin, then texel.
struct HatPiece {
    int texel, bin;
    double w[6];
};
std::vector<HatPiece> hat_pieces_lon(int texels, int bins);
std::vector<HatPiece> hat_pieces_lat(int texels, int bins);
// The pieces of the texels in `only` alone (any order, repeats allowed; each
// in [0, texels), else std::out_of_range), to the bit those of the whole
// call: for the few hot texels of a large source, whose every hat was
// computed (16K + 8K of them, 10-20 ms) to read a handful.
std::vector<HatPiece> hat_pieces_lon(int texels, int bins, const std::vector<int>& only);
std::vector<HatPiece> hat_pieces_lat(int texels, int bins, const std::vector<int>& only);

}  // namespace iblbake
