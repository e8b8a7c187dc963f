// The seed algorithms (../shared/seeds), written in C++ the way the seeds
// write them, for the benchmark's "same run, same machine" baselines. Single
// precision like the shaders; every radiance read is SPEC.md section 1's
// bilinear lat-long lookup (ibl/source.h). Parallel over output texels (TBB),
// like the library.
#pragma once
#include <cstdint>
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/math/vec3.h"

namespace iblbake::bench {

// Van der Corpus radical inverse in base 2 and the Hammersley point (i/N, phi2(i)).
float radical_inverse_vdc(uint32_t bits);

// Seed 000 (learnopengl / UE4): the split-sum LUT by `samples` Hammersley
// points of GGX importance sampling of h, Schlick-GGX G with k = alpha / 2,
// A += (1 - Fc) G_Vis, B += Fc G_Vis, divided by the sample count.
// size x size, texel (i, j) from the top: NdotV = (i + .5)/N, r = (j + .5)/N.
Image seed_brdf_lut(int size, int samples);

// Seed 003 (learnopengl's irradiance shader): per output texel, the Riemann
// sum of L cos(theta) sin(theta) over phi in [0, 2 pi) and theta in
// [0, pi/2) with step `delta` (0.025 in the seed), times pi / sample count.
// That is SPEC's Irr (already divided by pi). The tangent frame is made
// orthonormal as in learnopengl (the seed's Unity port omits normalize()).
Cubemap seed_irradiance(const Image& src, int face, float delta);
// The same for one engine-space unit normal n (what each texel runs).
void seed_irradiance_at(const Image& src, const Vec3& n, float delta, float out[3]);

// learnopengl's prefilter shader without the mip-level trick: per texel of
// level m (face max(1, face >> m), r_m = m / (M - 1)), `samples` Hammersley
// points of GGX importance sampling of h with N = V = R = n, L = reflect(-V, h),
// sum of L(w) NdotL / sum of NdotL, every read the bilinear source lookup.
// Level 0 (r = 0, where every sample is n itself) is one lookup per texel.
struct SeedSpecular {
    std::vector<Cubemap> levels;
    std::vector<double> roughness;
};
SeedSpecular seed_specular(const Image& src, int face, int samples);
// One texel of it: direction n (engine space, unit), roughness > 0.
void seed_prefilter_at(const Image& src, const Vec3& n, float roughness, int samples, float out[3]);

}  // namespace iblbake::bench
