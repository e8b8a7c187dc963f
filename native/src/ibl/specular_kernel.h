// The hierarchical specular sum's inner loop (specular.cpp), the SH9
// projection's row sums (source.cpp), mip 0's lat-long coordinates
// (specular_mirror) and the irradiance's cosine sums (irradiance.cpp),
// built once per
// instruction set in its own translation unit (specular_kernel_*.cpp, each
// compiled with its own -m flags) and chosen at run time: the library itself
// is built for the baseline x86-64 and runs on any CPU.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace iblbake {
namespace kernel {

// The fields of the bins a tile uses, structure-of-arrays: unit centroid p,
// g = 1 - |m|, power per channel, covariance (xx, yy, zz, xy, xz, yz).
enum Field { kPx, kPy, kPz, kG, kP0, kP1, kP2, kCxx, kCyy, kCzz, kCxy, kCxz, kCyz, kFields };

constexpr size_t kLanes = 16;  // independent partial sums: the order stays fixed
constexpr int kMaxLobes = 4;

// For `lobes` GGX lobes (1..kMaxLobes, a2[k] = alpha_k^2) at `texels`
// directions n (dirs[3 q .. 3 q + 2], q < texels), sum_b power_b E_b[k(n.w)]
// over `count` bins (a multiple of kLanes), k the prefilter kernel up to its
// constant factor 4 a^2 / pi, by the second- and fourth-order rule from each
// bin's moments (specular.cpp). The bins' loads are shared by the texels of
// one call (texels_per_call at a time), their distances and variances by the
// lobes; each texel's sums are the same to the bit however many share the
// call. num[q][k][ch].
constexpr int texels_per_call(int lobes) { return lobes <= 1 ? kMaxLobes : lobes >= kMaxLobes ? 1 : kMaxLobes / lobes; }
using SumsFn = void (*)(const float* const* fields, size_t count, int lobes, const float* a2, const float* dirs,
                        int texels, double (*num)[kMaxLobes][3]);

// One per instruction set; the avx2 and avx512 ones exist only on x86-64.
void sums_baseline(const float* const* fields, size_t count, int lobes, const float* a2, const float* dirs, int texels,
                   double (*num)[kMaxLobes][3]);
void sums_avx2(const float* const* fields, size_t count, int lobes, const float* a2, const float* dirs, int texels,
               double (*num)[kMaxLobes][3]);
void sums_avx512(const float* const* fields, size_t count, int lobes, const float* a2, const float* dirs, int texels,
                 double (*num)[kMaxLobes][3]);

// A bin row's five column sums over its row pieces (source.cpp's
// add_row_pieces), the whole blocks of 8 to 32 values; returns the first
// value not summed. Each value's products with the five centred weights
// are summed in float, then the raw sums rebuilt in double (rebuild_sums,
// centre = {s0, c0}). The same bits for every instruction set (no FMA).
using RowPiecesFn = size_t (*)(const float* const* src, const float* w, size_t pieces, size_t n,
                               const double* centre, double* const* out);
size_t row_pieces_baseline(const float* const* src, const float* w, size_t pieces, size_t n, const double* centre,
                           double* const* out);
size_t row_pieces_avx2(const float* const* src, const float* w, size_t pieces, size_t n, const double* centre,
                       double* const* out);
size_t row_pieces_avx512(const float* const* src, const float* w, size_t pieces, size_t n, const double* centre,
                         double* const* out);
// The sums of L times 1, s, s^2, c, s c (into out[0..4]) from those of L
// times the centred terms 1, s - s0, (s - s0)^2, c - c0, (s - s0)(c - c0)
// (in S[0..4]), s0 = centre[0], c0 = centre[1]: for a double or a vector of
// doubles, one expression, so the kernels and the scalar tail agree to the
// bit. Built with fp-contract off itself: GCC 10 (the wheels' compiler) does
// not inline it into the kernels, whose units allow FMA, and its own copy
// then fused the products (the wheels' SH9 differed from the CLI's).
template <typename T>
__attribute__((optimize("fp-contract=off"))) inline void rebuild_sums(const T S[5], const double* centre, T out[5]) {
    const double s0 = centre[0], c0 = centre[1];
    const double two_s0 = 2.0 * s0, s0s0 = s0 * s0, s0c0 = s0 * c0;
    out[0] = S[0];
    out[1] = S[1] + s0 * S[0];
    out[2] = S[2] + two_s0 * S[1] + s0s0 * S[0];
    out[3] = S[3] + c0 * S[0];
    out[4] = S[4] + s0 * S[3] + c0 * S[1] + s0c0 * S[0];
}
RowPiecesFn row_pieces_fn();

// A bin row's band-2 SH9 sums from its five column sums (row_kernels_impl.h),
// added into acc: value i (i = 3 x + c over `width` columns, channel c)
// into lane i mod 24 of acc[k] for k in {cs2, q, q h2, q h3, cc1 h0,
// cc1 h1}, q = cs0 - cs2, h = sh9_hat_tables' four tables from the first
// column. A row may come in pieces of whole multiples of 8 columns (the
// last of any width): each lane adds its values in the same order, so the
// pieces give the bits of one call. The caller adds each channel's lanes
// (c, c + 3, ..., c + 21) in order. The same bits for every instruction set
// (no FMA).
using Sh9Band2Fn = void (*)(const double* cs0, const double* cs2, const double* cc1, const double* const* h,
                            size_t width, double (*acc)[24]);
void sh9_band2_baseline(const double* cs0, const double* cs2, const double* cc1, const double* const* h, size_t width,
                        double (*acc)[24]);
void sh9_band2_avx2(const double* cs0, const double* cs2, const double* cc1, const double* const* h, size_t width,
                    double (*acc)[24]);
void sh9_band2_avx512(const double* cs0, const double* cs2, const double* cc1, const double* const* h, size_t width,
                      double (*acc)[24]);
Sh9Band2Fn sh9_band2_fn();
// Column x's longitude hat (SPEC's bilinear L: a tent of half-width p0 =
// 2 pi / width about phi_x) integrated against cos phi, sin phi,
// cos phi sin phi and cos^2 phi - 1/2, in closed form: the tent's Fourier
// transform, p0 sinc^2(k p0 / 2) at frequency k, gives h[0..3] = p0 k1
// (cos, sin) phi_x and p0 k2 / 2 (cos, sin) 2 phi_x; returns p0 (source.cpp).
double sh9_hat_tables(int width, std::vector<double> (&h)[4]);


// Lat-long coordinates of a cube face row's texel centres, in source texel
// units as latlong_bilinear takes them (fx = u w - 0.5 with u wrapped to
// [0, 1), fy = (1 - v) h - 0.5): frame = the face's ma, s, t (engine space,
// 9 doubles), b = the row's t coordinate in (-1, 1), n texels.
using MirrorRowFn = void (*)(const double* frame, double b, int n, int w, int h, double* fx, double* fy);
void mirror_row_baseline(const double* frame, double b, int n, int w, int h, double* fx, double* fy);
void mirror_row_avx2(const double* frame, double b, int n, int w, int h, double* fx, double* fy);
void mirror_row_avx512(const double* frame, double b, int n, int w, int h, double* fx, double* fy);
MirrorRowFn mirror_row_fn();

// The irradiance's groups wholly on one side of n's horizon (irradiance.cpp):
// whole[p] = 1 where |n.c_p| > sin_radius[p], else 0, for p < count.
using IrrHorizonFn = void (*)(const float* cx, const float* cy, const float* cz, const float* sin_radius,
                              size_t count, float nx, float ny, float nz, float* whole);
// And their cosine sum: sum over p < count of whole[p] max(0, n.(x, y, z)_p),
// count a multiple of 16, in 16 float lanes within blocks of 256, double
// across blocks (the same order for every instruction set).
using IrrSumFn = double (*)(const float* x, const float* y, const float* z, const float* whole, size_t count,
                            float nx, float ny, float nz);
void irr_horizon_baseline(const float*, const float*, const float*, const float*, size_t, float, float, float, float*);
void irr_horizon_avx2(const float*, const float*, const float*, const float*, size_t, float, float, float, float*);
void irr_horizon_avx512(const float*, const float*, const float*, const float*, size_t, float, float, float, float*);
double irr_sum_baseline(const float*, const float*, const float*, const float*, size_t, float, float, float);
double irr_sum_avx2(const float*, const float*, const float*, const float*, size_t, float, float, float);
double irr_sum_avx512(const float*, const float*, const float*, const float*, size_t, float, float, float);
IrrHorizonFn irr_horizon_fn();
IrrSumFn irr_sum_fn();


// One level of the specular traversal (specular.cpp's gather_bins) in lanes:
// for the n nodes cur[0..n) of a level (nodes: 16 floats each, BinNode's
// layout, fields at the offsets below), the scalar loop's decisions to the
// bit; the accepted nodes appended to accepted[*n_accepted..], those to
// visit further (not at the last level) to split[*n_split..], in order.
// null where the CPU (or IBLBAKE_ISA) has no such version: the scalar loop runs.
constexpr int kNodePx = 0, kNodePy = 1, kNodePz = 2, kNodeRadius = 13, kNodeFloats = 16;
using TraverseLevelFn = void (*)(const float* nodes, const uint32_t* cur, size_t n, int last, const float* c,
                                 float rho, float scale, float eps, float horizon_radius, uint32_t* accepted,
                                 size_t* n_accepted, uint32_t* split, size_t* n_split);
void traverse_level_avx512(const float* nodes, const uint32_t* cur, size_t n, int last, const float* c, float rho,
                           float scale, float eps, float horizon_radius, uint32_t* accepted, size_t* n_accepted,
                           uint32_t* split, size_t* n_split);
TraverseLevelFn traverse_level_fn();

// The accepted nodes' fields, structure-of-arrays (gather_bins): for the n
// nodes nodes[0..n) (BinNode's layout, 64-byte aligned), floats 0..kFields
// of node k into fields[f][k] (BinNode's first floats are Field's order);
// the k whose chroma word (float kNodeChroma) is not 0, the tinted, into
// chroma_at[0..*n_chroma) in order, and their rows for chroma_pass into
// tinted[r][0..*n_chroma) (Tinted: p, radius, the three scores as
// BinNode::chroma_score gives them, the power). The same values as the
// scalar loop. null where traverse_level_fn() is.
constexpr int kNodeChroma = 14, kNodeScores = 15;
enum Tinted { kTx, kTy, kTz, kTBeta, kTScore0, kTScore1, kTScore2, kTP0, kTP1, kTP2, kTinted };
using NodeFieldsFn = void (*)(const float* const* nodes, size_t n, float* const* fields, uint32_t* chroma_at,
                              float* const* tinted, size_t* n_chroma);
void node_fields_avx512(const float* const* nodes, size_t n, float* const* fields, uint32_t* chroma_at,
                        float* const* tinted, size_t* n_chroma);
NodeFieldsFn node_fields_fn();

}  // namespace kernel
}  // namespace iblbake
