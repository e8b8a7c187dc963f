// GGX prefiltered specular radiance (SPEC.md section 3), N = V = R = n:
//   Pre(n, r) = int L(w) D(h) max(0, n.w) dw / int D(h) max(0, n.w) dw.
#pragma once
#include <string>
#include <cstdint>
#include <vector>

#include "iblbake/ibl/bin_tree.h"
#include "iblbake/ibl/cube_sampling.h"
#include "iblbake/ibl/source.h"

namespace iblbake {

struct SpecularQuality {
    int rings = 12;         // Gauss-Legendre nodes in the GGX CDF variable u
    int min_phi = 6;        // azimuthal samples per ring, at least ...
    int max_phi = 48;       // ... and at most
    float lod_bias = 1.0f;  // added to the footprint's mip level
};

// One deterministic sample of the kernel in n's tangent frame.
struct KernelSample {
    float t, b, n;     // local direction (tangent, bitangent, normal components)
    float weight;      // quadrature weight of the self-normalised estimator
    float lod_base;    // 0.5 * log2(footprint solid angle) + bias
};

// The sample set for roughness r: rings at Gauss-Legendre nodes of u on
// [0, 1/(1+a^2)] (the part of the lobe with n.w > 0, so no kink inside),
// each ring split into roughly square cells in phi. This is filtered
// importance sampling (Krivanek and Colbert 2008, "Real-time Shading with
// Filtered Importance Sampling") with a product Gauss rule in place of random
// points: the pdf is D(h) cos(theta_h), the footprint of each sample is the
// solid angle of its cell, and the mip level is chosen from it.
std::vector<KernelSample> make_kernel_samples(double roughness, const SpecularQuality& q, int base_face);

// Mip 0 (r = 0): the bilinear source lookup L(n) at every texel centre.
void specular_mirror(Cubemap& dst, ImageView latlong);

// specular_mirror as a source is decoded in bands (issue 28,
// docs/design-streaming.md): add_rows() looks up every texel of `dst` whose
// last source row (of the two a bilinear lookup reads) is in y0..y1 and was
// not in an earlier band, so bands come in order and overlap by at least
// one row. Every texel is written once pending() is 0, equal to the bit to
// specular_mirror(dst, whole image). Texels are bucketed by that row up
// front (side faces: n^2 places shared by the four; top and bottom: 2 n^2),
// so a band touches only its own texels. Holds the lookups' coordinates and
// the buckets: about 52 n^2 bytes (52 MB at n = 1024).
class MirrorStream {
public:
    MirrorStream(Cubemap& dst, int src_w, int src_h);
    void add_rows(ImageView img, int y0, int y1);
    size_t pending() const { return pending_; }

private:
    Cubemap& dst_;
    int n_, w_, h_;
    std::vector<double> side_fx_;        // 4 faces x n columns
    std::vector<double> side_fy_;        // n rows x n columns (every side face's)
    std::vector<double> polar_fx_, polar_fy_;  // 2 faces x n x n
    // Texels by last source row: bucket y holds order[start[y] .. start[y + 1]).
    std::vector<uint32_t> side_order_, side_start_, polar_order_, polar_start_;
    int last_row_ = -1;  // rows up to here were served
    size_t pending_ = 0;
};

// Level for roughness r > 0: filtered importance sampling of `rest` plus the
// exact kernel sum over the hot points divided by the analytic normaliser.
// Returns the number of samples per texel.
size_t specular_prefilter(Cubemap& dst, const CubePyramid& rest, const std::vector<RadiancePoint>& hot,
                        double roughness, const SpecularQuality& q);

struct HierarchicalQuality {
    double eps = 0.5;  // a bin is used whole when its radius <= eps * the kernel's length scale there
    // Output texels share one traversal per tile x tile block; 0: automatic,
    // 8, or 16 on faces of 512 and more (where one traversal per 64 texels
    // cost more than the finer bins a wider tile takes; measured).
    int tile = 0;
    // The finest bins' radius <= finest_eps * 2 alpha of the narrowest lobe
    // (0.35 cost a tree of 4x the bins for a level at r = 0.1 and moved its
    // worst texel only from 0.29 % to 0.22 % on sunset.exr; measured).
    double finest_eps = 0.5;
    double horizon = 0.05;     // bins that may straddle a texel's horizon: radius <= eps horizon / sqrt(D(45 deg) / Z)
    // Bins of varying colour (bin_tree.h's ChromaBin) have their channels
    // taken on their own, largest estimated error first, while the errors
    // of those taken whole add up to more than this times a tile's least
    // value in some channel (that of its corner texels' sums over the bins
    // whole; at least 0.05 x the channel's mean, the metric's floor); 0:
    // every one, negative: none. 0.01: measured (issue
    // 25, docs/benchmarks.md): 11 sources within 0.86 % per channel; 0.02
    // left the red sun at 1.6 % (r = 0.125), 0.005 cost 1.5x to 2x the
    // extra bins.
    double chroma = 0.01;
};

// Level for roughness r > 0 by a hierarchical (Barnes-Hut) kernel sum over a
// bin pyramid: for each tile of output texels, bins are taken whole where
// they are small against the kernel's local length scale, max(2 alpha, the
// bin's least distance to the tile), else split down to the finest level.
// Each bin is integrated by a second-order rule from its radiance's moments
// (mean m and covariance C of w):
//   Pre(n) = sum_b P_b [k(n.m_b) + k''(n.m_b) n^T C_b n / 2] / Z,
// with Z the kernel's integral in closed form; a bin whose colour varies
// (bin_tree.h) is taken channel by channel, each with its own moments,
// where that matters (HierarchicalQuality::chroma). The result is a deterministic
// quadrature of SPEC.md's integral over the bilinear L whose error is set
// by eps, with no sampling noise and no clamping.
// Returns the mean number of bins per texel (a bin's channels taken alone
// counted as bins, a bin with all three taken not counted whole).
double specular_hierarchical(Cubemap& dst, const BinTree& tree, double roughness, const HierarchicalQuality& q = {});

// Up to four levels of one face size in one pass (engine presets bake levels
// at nearby roughness values): one traversal, by the narrowest lobe among
// them and the strictest horizon rule (bins at least as fine as each lobe
// alone would use, so none loses accuracy), each bin's fields loaded and its
// distance and variance computed once for every lobe; each lobe divided by
// its own closed-form normaliser. A level's values depend on its group (on
// the bins the narrowest lobe chose) within the integration error.
// Returns the mean number of bins per texel.
struct SpecularGroupTarget {
    Cubemap* dst;
    double roughness;
};
double specular_hierarchical_group(std::vector<SpecularGroupTarget>& targets, const BinTree& tree,
                                   const HierarchicalQuality& q = {});
// Whether these roughness values can share a group: at most four, each in (0, 1].
bool specular_group_safe(const std::vector<double>& roughness);

// The instruction set the hierarchical sum's kernel runs on: "avx512",
// "avx2" or "baseline" (x86-64 with SSE2, or any other CPU). The library is
// built for the baseline; the best kernel the CPU has is chosen once per
// process, unless the environment variable IBLBAKE_ISA names a lesser one
// (baseline, avx2, avx512).
const char* specular_kernel_isa();
// Switches the kernel ("" = the best the CPU has), for tests and
// measurements. Returns false (and changes nothing) when the CPU lacks it;
// throws std::invalid_argument for an unknown name.
bool set_specular_kernel_isa(const std::string& isa);
// The traversal's decisions in AVX-512 lanes (on by default where the kernel
// runs as avx512; the same decisions as the scalar loop, to the bit). For
// tests: false turns them off; returns whether the lanes would run.
bool set_specular_traversal_lanes(bool on);

// The eps a level of this face size uses: q.eps from face 64 up, less below
// (sqrt(face / 64), at least half): small levels are cheap and their wide
// lobes the least forgiving of large bins.
double hierarchical_level_eps(const HierarchicalQuality& q, int face);
// The largest radius of a bin that may straddle a texel's horizon at this
// roughness: level eps * horizon / sqrt(D(45 deg) / Z). The finest bins
// should not exceed it.
double hierarchical_horizon_radius(double roughness, int face, const HierarchicalQuality& q);

}  // namespace iblbake
