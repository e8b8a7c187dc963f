// GGX prefiltered specular radiance (SPEC.md section 3), N = V = R = n:
//   Pre(n, r) = int L(w) D(h) max(0, n.w) dw / int D(h) max(0, n.w) dw.
#pragma once
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

// Level for roughness r > 0: filtered importance sampling of `rest` plus the
// exact kernel sum over the hot points divided by the analytic normaliser.
// Returns the number of samples per texel.
size_t specular_prefilter(Cubemap& dst, const CubePyramid& rest, const std::vector<RadiancePoint>& hot,
                        double roughness, const SpecularQuality& q);

struct HierarchicalQuality {
    double eps = 0.25;  // a bin is used whole when its radius <= eps * the kernel's length scale there
    int tile = 8;       // output texels share one traversal per tile x tile block
};

// Level for roughness r > 0 by a hierarchical (Barnes-Hut) kernel sum over a
// bin pyramid: for each tile of output texels, bins are taken whole where
// they are small against the kernel's local length scale, max(2 alpha, the
// bin's least distance to the tile), else split down to the finest level:
//   Pre(n) = sum_b P_b K(n.p_b) / sum_b Omega_b K(n.c_b),
// p_b the bin's power centroid, c_b its solid-angle centroid. The result is
// a deterministic quadrature of SPEC.md's integral whose error is set by eps
// alone (second order in eps), with no sampling noise and no clamping.
// Returns the mean number of bins per texel.
// The sum is a ratio: sum K power over sum K solid angle on the same bins, so
// a constant world comes out exact. The denominator depends on geometry alone
// (the bins' rectangles, which the tree takes from exact integrals, never
// from the source), so it can be kept and reused by any later bake with the
// same face size, roughness, eps, tile and finest bins: with `normaliser`
// holding 6 n^2 values (face, row, column order) they are used and only the
// numerator is summed (about 40 % less work); otherwise, given an empty
// vector, it is filled.
double specular_hierarchical(Cubemap& dst, const BinTree& tree, double roughness, const HierarchicalQuality& q = {},
                             std::vector<float>* normaliser = nullptr);

// Up to four levels of one face size in one pass (engine presets bake levels
// at nearby roughness values): one traversal, by the narrowest lobe among them
// (a finer set of bins than a broader lobe needs, so none loses accuracy), the
// distance to each bin computed once and one division per bin serving every
// lobe. A level's values depend on its group (on the narrowest lobe, and in
// the last bits on the others): its normaliser must be cached under a key
// that names the group. Each target's normaliser works as above. Returns the
// mean number of bins per texel.
struct SpecularGroupTarget {
    Cubemap* dst;
    double roughness;
    std::vector<float>* normaliser = nullptr;
};
double specular_hierarchical_group(std::vector<SpecularGroupTarget>& targets, const BinTree& tree,
                                   const HierarchicalQuality& q = {});
// Whether these roughness values can share a group: at most four, each in
// (0, 1], the product of the lobes' scaled denominators finite in float
// (about r >= 0.06 for four, r >= 0.03 for three).
bool specular_group_safe(const std::vector<double>& roughness);

}  // namespace iblbake
