// The body of the specular kernel, included by one translation unit per
// instruction set (specular_kernel_*.cpp) with IBLBAKE_KERNEL_NAME set to
// the function it defines. Everything here has internal linkage (an
// anonymous namespace, no library templates): code built with AVX-512 flags
// can never be shared with, or chosen by the linker for, another unit.
//
// Per bin b and lobe (a2 = alpha^2), with X = n.w over the bin's radiance,
// its mean mu = n.m and variance var = n^T C n (both exact),
//   E[k(X)] = k(mu) + k''(mu) var / 2 + k''''(mu) E[(X - mu)^4] / 24,
// k(c) = c / t^2, t = (1 - c)(1 - a2) + 2 a2, s = 1 - a2; with u = s / t,
// v = var u, cu = c u:
//   E[k] = t^-2 [c + v (2 + 3 cu + kurt v u (4 + 5 cu))],
// the fourth moment taken as kurt var^2 (kurt = 1.5), evaluated as
//   t^-2 [c + v ((2 + 3 cu) + v u (6 + 7.5 cu))]
// with c = n.m (m = (1 - g) p, the bin's mean direction) and t = (s + 2 a2)
// - s c: 27 operations per bin, texel and lobe (26 for one lobe with
// AVX-512) where the form through |n - p|^2 took 34. (t's rounding: c to
// about 1e-7, against t >= 2 a2: up to 3e-4 of k at the narrowest lobe's
// peak, r = 0.125, and under 3e-5 from r = 0.25; docs/benchmarks.md has the
// outputs' change.) Float lanes within blocks of 512 bins, double across.
// Up to kMaxLobes / lobes texels take
// each bin's fields from one load (a tile's bins outgrow the first-level
// cache at about 600): each texel's operations, and so its sums, are those
// it would have alone.
#include "specular_kernel.h"

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace iblbake {
namespace kernel {
namespace {

constexpr float kKurtosis = 1.5f;
constexpr float kK4 = 4.0f * kKurtosis, kK5 = 5.0f * kKurtosis;  // 6, 7.5: exact in float
constexpr size_t kBlock = 512;

inline size_t block_end(size_t b, size_t count) { return count < b + kBlock ? count : b + kBlock; }

#if defined(__AVX512F__)
// 16 lanes in one register; the reciprocal by rcp14 and one Newton step
// (within an ulp or two of the division).
template <int K, int T>
void sums(const float* const* f, size_t count, const float* a2, const float* dirs, double (*num)[kMaxLobes][3]) {
    for (int q = 0; q < T; ++q)
        for (int k = 0; k < K; ++k) num[q][k][0] = num[q][k][1] = num[q][k][2] = 0.0;
    __m512 vs[K], vst[K];
    for (int k = 0; k < K; ++k) {
        vs[k] = _mm512_set1_ps(1.0f - a2[k]);
        vst[k] = _mm512_set1_ps((1.0f - a2[k]) + 2.0f * a2[k]);  // t = vst - s c
    }
    // One lobe: the variance taken as s var (its constants times s), so
    // that v = (s var) it, c u = s (c it) and v u = s (v it), s going into
    // the polynomial's constants: u is not formed (26 operations).
    const float s1 = 1.0f - a2[0], vscale = K == 1 ? s1 : 1.0f;
    __m512 vnx[T], vny[T], vnz[T], nxx[T], nyy[T], nzz[T], nxy[T], nxz[T], nyz[T];
    for (int q = 0; q < T; ++q) {
        const float nx = dirs[3 * q], ny = dirs[3 * q + 1], nz = dirs[3 * q + 2];
        vnx[q] = _mm512_set1_ps(nx), vny[q] = _mm512_set1_ps(ny), vnz[q] = _mm512_set1_ps(nz);
        nxx[q] = _mm512_set1_ps(vscale * (nx * nx)), nyy[q] = _mm512_set1_ps(vscale * (ny * ny));
        nzz[q] = _mm512_set1_ps(vscale * (nz * nz)), nxy[q] = _mm512_set1_ps(vscale * (2.0f * nx * ny));
        nxz[q] = _mm512_set1_ps(vscale * (2.0f * nx * nz)), nyz[q] = _mm512_set1_ps(vscale * (2.0f * ny * nz));
    }
    const __m512 s3 = _mm512_set1_ps(3.0f * s1), s4 = _mm512_set1_ps(kK4 * s1), s5 = _mm512_set1_ps(kK5 * s1 * s1);
    const __m512 one = _mm512_set1_ps(1.0f), two = _mm512_set1_ps(2.0f), three = _mm512_set1_ps(3.0f);
    const __m512 k4 = _mm512_set1_ps(kK4), k5 = _mm512_set1_ps(kK5);
    for (size_t b = 0; b < count; b += kBlock) {
        const size_t e = block_end(b, count);
        __m512 acc[T][K][3];
        for (int q = 0; q < T; ++q)
            for (int k = 0; k < K; ++k) acc[q][k][0] = acc[q][k][1] = acc[q][k][2] = _mm512_setzero_ps();
        for (size_t p = b; p < e; p += kLanes) {
            // The bin's fields, loaded once for the T texels.
            const __m512 l = _mm512_sub_ps(one, _mm512_loadu_ps(f[kG] + p));  // |m|
            const __m512 mx = _mm512_mul_ps(l, _mm512_loadu_ps(f[kPx] + p)),
                         my = _mm512_mul_ps(l, _mm512_loadu_ps(f[kPy] + p)),
                         mz = _mm512_mul_ps(l, _mm512_loadu_ps(f[kPz] + p));
            const __m512 cxx = _mm512_loadu_ps(f[kCxx] + p), cyy = _mm512_loadu_ps(f[kCyy] + p),
                         czz = _mm512_loadu_ps(f[kCzz] + p), cxy = _mm512_loadu_ps(f[kCxy] + p),
                         cxz = _mm512_loadu_ps(f[kCxz] + p), cyz = _mm512_loadu_ps(f[kCyz] + p);
            const __m512 p0 = _mm512_loadu_ps(f[kP0] + p), p1 = _mm512_loadu_ps(f[kP1] + p),
                         p2 = _mm512_loadu_ps(f[kP2] + p);
            for (int q = 0; q < T; ++q) {
                const __m512 c = _mm512_fmadd_ps(vnz[q], mz, _mm512_fmadd_ps(vny[q], my, _mm512_mul_ps(vnx[q], mx)));
                __m512 var = _mm512_mul_ps(cxx, nxx[q]);
                var = _mm512_fmadd_ps(cyy, nyy[q], var);
                var = _mm512_fmadd_ps(czz, nzz[q], var);
                var = _mm512_fmadd_ps(cxy, nxy[q], var);
                var = _mm512_fmadd_ps(cxz, nxz[q], var);
                var = _mm512_fmadd_ps(cyz, nyz[q], var);
                const __mmask16 lit = _mm512_cmp_ps_mask(c, _mm512_setzero_ps(), _CMP_GT_OQ);
                for (int k = 0; k < K; ++k) {
                    const __m512 t = _mm512_fnmadd_ps(vs[k], c, vst[k]);
                    __m512 it = _mm512_maskz_rcp14_ps(0xffff, t);  // (rcp14_ps trips -Wmaybe-uninitialized on GCC 12)
                    it = _mm512_mul_ps(it, _mm512_fnmadd_ps(t, it, two));
                    __m512 v, inner;
                    if constexpr (K == 1) {
                        const __m512 ci = _mm512_mul_ps(c, it);
                        v = _mm512_mul_ps(var, it);
                        inner = _mm512_fmadd_ps(_mm512_mul_ps(v, it), _mm512_fmadd_ps(s5, ci, s4),
                                                _mm512_fmadd_ps(s3, ci, two));
                    } else {
                        const __m512 u = _mm512_mul_ps(vs[k], it), cu = _mm512_mul_ps(c, u);
                        v = _mm512_mul_ps(var, u);
                        inner = _mm512_fmadd_ps(_mm512_mul_ps(v, u), _mm512_fmadd_ps(k5, cu, k4),
                                                _mm512_fmadd_ps(three, cu, two));
                    }
                    const __m512 kv = _mm512_mul_ps(_mm512_mul_ps(it, it), _mm512_fmadd_ps(v, inner, c));
                    acc[q][k][0] = _mm512_mask3_fmadd_ps(kv, p0, acc[q][k][0], lit);
                    acc[q][k][1] = _mm512_mask3_fmadd_ps(kv, p1, acc[q][k][1], lit);
                    acc[q][k][2] = _mm512_mask3_fmadd_ps(kv, p2, acc[q][k][2], lit);
                }
            }
        }
        for (int q = 0; q < T; ++q)
            for (int k = 0; k < K; ++k)
                for (int ch = 0; ch < 3; ++ch) {
                    alignas(64) float lanes[kLanes];
                    _mm512_store_ps(lanes, acc[q][k][ch]);
                    float t = 0.0f;
                    for (size_t l = 0; l < kLanes; ++l) t += lanes[l];
                    num[q][k][ch] += t;
                }
    }
}
#else
// Plain lanes the compiler vectorises for the unit's instruction set (SSE2:
// 4 at a time, AVX2 + FMA: 8).
template <int K, int T>
void sums(const float* const* f, size_t count, const float* a2, const float* dirs, double (*num)[kMaxLobes][3]) {
    for (int q = 0; q < T; ++q)
        for (int k = 0; k < K; ++k) num[q][k][0] = num[q][k][1] = num[q][k][2] = 0.0;
    float s[K], st[K];
    for (int k = 0; k < K; ++k) {
        s[k] = 1.0f - a2[k];
        st[k] = (1.0f - a2[k]) + 2.0f * a2[k];  // t = st - s c
    }
    float nx[T], ny[T], nz[T], nxx[T], nyy[T], nzz[T], nxy[T], nxz[T], nyz[T];
    for (int q = 0; q < T; ++q) {
        nx[q] = dirs[3 * q], ny[q] = dirs[3 * q + 1], nz[q] = dirs[3 * q + 2];
        nxx[q] = nx[q] * nx[q], nyy[q] = ny[q] * ny[q], nzz[q] = nz[q] * nz[q];
        nxy[q] = 2.0f * nx[q] * ny[q], nxz[q] = 2.0f * nx[q] * nz[q], nyz[q] = 2.0f * ny[q] * nz[q];
    }
    const float *px = f[kPx], *py = f[kPy], *pz = f[kPz], *pg = f[kG], *q0 = f[kP0], *q1 = f[kP1], *q2 = f[kP2];
    const float *cxx = f[kCxx], *cyy = f[kCyy], *czz = f[kCzz], *cxy = f[kCxy], *cxz = f[kCxz], *cyz = f[kCyz];
    for (size_t b = 0; b < count; b += kBlock) {
        const size_t e = block_end(b, count);
        alignas(64) float acc[T][K][3][kLanes] = {};
        for (size_t p = b; p < e; p += kLanes) {
            for (size_t l = 0; l < kLanes; ++l) {
                const size_t r = p + l;
                const float ml = 1.0f - pg[r];  // |m|
                const float mx = ml * px[r], my = ml * py[r], mz = ml * pz[r];
                for (int q = 0; q < T; ++q) {
                    const float c = nx[q] * mx + ny[q] * my + nz[q] * mz;  // n.m
                    const float var = cxx[r] * nxx[q] + cyy[r] * nyy[q] + czz[r] * nzz[q] + cxy[r] * nxy[q] +
                                      cxz[r] * nxz[q] + cyz[r] * nyz[q];
                    const float lit = c > 0.0f ? 1.0f : 0.0f;
                    for (int k = 0; k < K; ++k) {
                        const float it = 1.0f / (st[k] - s[k] * c);
                        const float u = s[k] * it, v = var * u, cu = c * u;
                        const float kv = lit * (it * it * (c + v * ((2.0f + 3.0f * cu) + v * u * (kK4 + kK5 * cu))));
                        acc[q][k][0][l] += kv * q0[r];
                        acc[q][k][1][l] += kv * q1[r];
                        acc[q][k][2][l] += kv * q2[r];
                    }
                }
            }
        }
        for (int q = 0; q < T; ++q)
            for (int k = 0; k < K; ++k)
                for (int ch = 0; ch < 3; ++ch) {
                    float t = 0.0f;
                    for (size_t l = 0; l < kLanes; ++l) t += acc[q][k][ch][l];
                    num[q][k][ch] += t;
                }
    }
}
#endif

}  // namespace

void IBLBAKE_KERNEL_NAME(const float* const* f, size_t count, int lobes, const float* a2, const float* dirs,
                         int texels, double (*num)[kMaxLobes][3]) {
    // K lobes at T texels a call, K T <= kMaxLobes: the accumulators stay
    // in registers.
    const int per_call = texels_per_call(lobes);
    for (int q = 0; q < texels; q += per_call) {
        const int m = texels - q < per_call ? texels - q : per_call;
        const float* d = dirs + 3 * q;
        double(*nq)[kMaxLobes][3] = num + q;
        switch (lobes * 8 + m) {
            case 9: sums<1, 1>(f, count, a2, d, nq); break;
            case 10: sums<1, 2>(f, count, a2, d, nq); break;
            case 11: sums<1, 3>(f, count, a2, d, nq); break;
            case 12: sums<1, 4>(f, count, a2, d, nq); break;
            case 17: sums<2, 1>(f, count, a2, d, nq); break;
            case 18: sums<2, 2>(f, count, a2, d, nq); break;
            case 25: sums<3, 1>(f, count, a2, d, nq); break;
            default: sums<4, 1>(f, count, a2, d, nq); break;
        }
    }
}

}  // namespace kernel
}  // namespace iblbake
