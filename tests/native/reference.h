// The exhaustive reference integrator the tests measure errors against:
// every source texel, its exact solid angle, double precision (SPEC.md 3).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/math/vec3.h"

namespace iblbake::ref {

using Rgb = std::array<double, 3>;

// SPEC.md section 1's L(w): the bilinear reconstruction of a source (wrapping
// in u, clamped at the top and bottom rows), integrated exactly: L is
// bilinear in (u, v) on each cell between four texel centres (and linear in u
// on the two polar caps), so every integral below is a sum over those cells of
// Gauss-Legendre rules in (u, v) with dOmega = 2 pi^2 cos(lat) du dv. Far from
// n a cell takes a 2 x 2 rule (relative error below 1e-6 there); cells near n
// or the kernel's core are split so that every piece is at most 0.15 of the
// kernel's length scale and take 3 x 3 rules; cells that straddle n's horizon
// (the kink of max(0, n.w)) are split 8 x 8. Double precision throughout.
struct TexelTable {
    const Image* src = nullptr;
    int w = 0, h = 0;
    // Column nodes, two per cell column (cell x spans the centres of columns
    // x and x + 1), by node g: cos and sin of the longitude at node g of cell x.
    std::vector<double> cphi[2], sphi[2];
    // Row nodes, two per cell row (cell row y = 0 .. h spans the centres of
    // rows y - 1 and y; rows 0 and h are the polar caps): cos and sin of the
    // latitude and the rule's weight times the Jacobian and the cell's extent.
    std::vector<double> clat, slat, wrow;
    // Per cell column: centre longitude; per cell row: centre latitude and the
    // cell's angular radius (any cell of a row has the same).
    std::vector<double> ccphi, csphi, cclat, cslat, crad, sin_crad;
    // Per row node and channel: the row's L at every column (and column 0
    // again at the end), interpolated in v: planar, (w + 1) values.
    std::vector<float> lv;
};
TexelTable texel_table(const Image& src);  // keeps a pointer to src

// (1/pi) integral L(w) max(0, n.w) dw; n is an engine-space unit direction.
Rgb irradiance(const TexelTable& t, const Vec3d& n);
Rgb irradiance(const Image& src, const Vec3d& n);
// integral L K / integral K, K = D(h) max(0, n.w) (SPEC.md 3); r = 0 is the bilinear lookup.
Rgb prefiltered(const TexelTable& t, const Vec3d& n, double roughness);
Rgb prefiltered(const Image& src, const Vec3d& n, double roughness);
// The same quadrature's integral of K alone (for the tests: against the closed form).
double kernel_integral(const TexelTable& t, const Vec3d& n, double roughness);
// The earlier, texel-constant sums (every texel a point at its centre with
// its exact solid angle), second-order close to the above.
Rgb irradiance_constant(const Image& src, const Vec3d& n);
Rgb prefiltered_constant(const Image& src, const Vec3d& n, double roughness);

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

// The accuracy metric of issue 14, per texel on the channel sum:
//   e = |out - ref| / max(ref, floor * mean),
// mean the mean of L (every level's mean; floor 0.05), its maximum over every
// texel of small levels and every texel near a bright feature of large ones,
// plus, over a uniform random sample (all texels of small levels), the
// solid-angle RMS of out - ref relative to the reference's solid-angle RMS,
// the energy bias (sum Omega out / sum Omega ref - 1) and the old relative RMSE.
constexpr double kErrorFloor = 0.05;
inline double texel_error(double out, double ref, double mean) { return std::fabs(out - ref) / std::max(ref, kErrorFloor * mean); }

// Directions (engine space) of a source's bright features: texels whose
// channel sum exceeds max(16 x the mean, 5 % of the largest), merged per cell
// of a 256 x 128 grid at their power centroid; with each, its angular radius
// (the cell's). At most `max_features` of the brightest cells.
struct BrightFeature { Vec3d dir; double radius; double power; };
std::vector<BrightFeature> bright_features(const Image& src, size_t max_features = 64);

// The texels a level is measured at: every texel when n <= small_face, else
// `per_level` drawn at random plus every texel within max(6 alpha, 3 texels)
// (at most 30 degrees) of a bright feature. `random` marks the uniform sample
// (all texels of small levels), on which the RMS and bias are taken.
struct MeasureTexel { CubeTexel t; bool random; };
std::vector<MeasureTexel> measure_texels(int n, double roughness, const std::vector<BrightFeature>& bright,
                                         int per_level, int small_face, unsigned seed);

struct LevelAccuracy {
    size_t texels = 0, random_texels = 0;
    double max_e = 0, p99_e = 0;       // issue 14's metric over all measured texels
    double sa_rms = 0;                 // solid-angle RMS of the error / that of the reference (random sample)
    double bias = 0;                   // sum Omega out / sum Omega ref - 1 (random sample)
    double rel_rmse = 0, rel_p99 = 0;  // the old metric: |out - ref| / ref, RMS and p99 (random sample)
    CubeTexel worst{};                 // where max_e is
    double worst_ref = 0, worst_out = 0;
};
// out, ref: channel sums at `texels` (same order), n the level's face size.
LevelAccuracy level_accuracy(const std::vector<MeasureTexel>& texels, const std::vector<double>& out,
                             const std::vector<double>& ref, int n, double mean);

// Issue 25's metric, per colour channel: e_c = |out_c - ref_c| /
// max(ref_c, floor x mean_c), mean_c the mean of channel c of L (the
// level's), and the statistics above taken per channel, then the largest
// over the channels (|bias| for the bias): a weak channel beside a strong one
// is judged on its own, not hidden in the channel sum.
struct ChannelAccuracy {
    LevelAccuracy channel[3];  // each channel alone
    double max_e = 0, p99_e = 0, sa_rms = 0, bias = 0;  // the worst channel's (bias: the largest |bias|, signed)
    int worst_channel = 0;     // where max_e is
};
inline double texel_error_rgb(const Rgb& out, const Rgb& ref, const Rgb& mean, int* channel = nullptr) {
    double e = -1.0;
    for (int c = 0; c < 3; ++c) {
        const double ec = std::fabs(out[c] - ref[c]) / std::max(ref[c], kErrorFloor * mean[c]);
        if (ec > e) {
            e = ec;
            if (channel) *channel = c;
        }
    }
    return e;
}
ChannelAccuracy level_accuracy_rgb(const std::vector<MeasureTexel>& texels, const std::vector<Rgb>& out,
                                   const std::vector<Rgb>& ref, int n, const Rgb& mean);

// Test sources (Blender lat-long).
Image constant_source(int w, int h, float value);
Image random_smooth_source(int w, int h, unsigned seed);  // positive, a few octaves
// A disc of `radius_deg` and radiance `sun` around the Blender direction `dir`, on a `sky` background.
Image sun_source(int w, int h, const Vec3d& blender_dir, double radius_deg, float sun, float sky);
// Issue 25's chromatic contrast: a red sun disc of `radius_deg` around the
// Blender direction `dir`, radiance sun x (1, 0.1, 0) (no blue at all, as
// sunset.exr's sun has next to none), in a blue sky sky x (0.1, 0.3, 1) x
// (0.5 + 0.5 max(0, z)) (blue to red 10:1).
Image red_sun_source(int w, int h, const Vec3d& blender_dir, double radius_deg, float sun, float sky);
// Solid-angle-weighted mean radiance per channel (texel-constant radiance).
std::array<double, 3> mean_radiance(const Image& img);
// The mean of SPEC's bilinear L per channel (every level of Pre has this mean).
std::array<double, 3> mean_radiance(const TexelTable& t);

}  // namespace iblbake::ref
