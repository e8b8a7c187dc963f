// The exhaustive reference integrator the tests measure errors against:
// every source texel, its exact solid angle, double precision (SPEC.md 3).
#pragma once
#include <array>
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/math/vec3.h"

namespace iblbake::ref {

using Rgb = std::array<double, 3>;

// Every texel of a source with its engine direction and exact solid angle,
// tabulated once (the sums below visit them all for every output texel).
struct TexelTable {
    const Image* src = nullptr;
    std::vector<double> x, y, z;  // engine-space texel centre directions, row-major
    std::vector<double> omega;    // solid angle per row
};
TexelTable texel_table(const Image& src);  // keeps a pointer to src

// (1/pi) sum_t L_t Omega_t max(0, n.w_t); n is an engine-space unit direction.
Rgb irradiance(const TexelTable& t, const Vec3d& n);
Rgb irradiance(const Image& src, const Vec3d& n);
// sum_t L_t Omega_t K(n.w_t) / sum_t Omega_t K(n.w_t); r = 0 is the bilinear lookup.
Rgb prefiltered(const TexelTable& t, const Vec3d& n, double roughness);
Rgb prefiltered(const Image& src, const Vec3d& n, double roughness);
// A and B by a dense midpoint rule in (theta_h, phi) over the whole hemisphere
// of h, with no splitting: an estimator independent of the library's quadrature.
std::array<double, 2> brdf_karis(double ndotv, double roughness, int n_theta, int n_phi);

// A cube texel, and up to k texels of an n x n cube drawn at random (all of
// them when there are at most k), the same for the same seed.
struct CubeTexel { int f, i, j; };
std::vector<CubeTexel> sample_texels(int n, int k, unsigned seed);

// Relative error statistics of a cube against the reference, per texel,
// on the channel sum.
struct ErrorStats { double max_rel = 0, mean_rel = 0, rms_rel = 0, p99_rel = 0; };

// Test sources (Blender lat-long).
Image constant_source(int w, int h, float value);
Image random_smooth_source(int w, int h, unsigned seed);  // positive, a few octaves
// A disc of `radius_deg` and radiance `sun` around the Blender direction `dir`, on a `sky` background.
Image sun_source(int w, int h, const Vec3d& blender_dir, double radius_deg, float sun, float sky);
// Solid-angle-weighted mean radiance per channel (texel-constant radiance).
std::array<double, 3> mean_radiance(const Image& img);

}  // namespace iblbake::ref
