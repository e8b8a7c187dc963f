// One level of the hierarchical specular sum's tree traversal (gather_bins
// in specular.cpp) for 16 nodes at a time with AVX-512: gathers of the
// nodes' centroid and radius, the decisions in lanes, compress-stores of the
// accepted and the split nodes in their order. Built with -mavx512f and
// -ffp-contract=off (native/CMakeLists.txt) and written with the scalar
// loop's operations in the scalar loop's order (no fused multiply-add, the
// same comparisons, min/max picked to give what std::min/std::max give for
// NaN and signed zeros), so its decisions are the scalar loop's to the bit
// (ctest -R TraversalLanes). Nothing here is inline or shared with another
// unit: only intrinsics and this one function.
// GCC 12's AVX-512 headers make it warn of their own _mm512_undefined_*()
// placeholders as maybe uninitialized (GCC bug 105593), at -O3, for masked
// and mask-producing intrinsics: not this file's values.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>

#include <cstddef>
#include <cstdint>

#include "specular_kernel.h"

namespace iblbake {
namespace kernel {

namespace {

// fast_acos (math/fast_math.h) in lanes.
__m512 acos_lanes(__m512 x) {
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512 ax = _mm512_abs_ps(x);
    // fabs(x) < 1 ? fabs(x) : 1 (NaN: 1): minps returns its second operand for NaN.
    const __m512 a = _mm512_min_ps(ax, one);
    __m512 p = _mm512_set1_ps(-0.0012624911f);
    p = _mm512_add_ps(_mm512_mul_ps(p, a), _mm512_set1_ps(0.0066700901f));
    p = _mm512_sub_ps(_mm512_mul_ps(p, a), _mm512_set1_ps(0.0170881256f));
    p = _mm512_add_ps(_mm512_mul_ps(p, a), _mm512_set1_ps(0.0308918810f));
    p = _mm512_sub_ps(_mm512_mul_ps(p, a), _mm512_set1_ps(0.0501743046f));
    p = _mm512_add_ps(_mm512_mul_ps(p, a), _mm512_set1_ps(0.0889789874f));
    p = _mm512_sub_ps(_mm512_mul_ps(p, a), _mm512_set1_ps(0.2145988016f));
    p = _mm512_add_ps(_mm512_mul_ps(p, a), _mm512_set1_ps(1.5707963050f));
    const __m512 r = _mm512_mul_ps(_mm512_sqrt_ps(_mm512_sub_ps(one, a)), p);
    const __mmask16 nonneg = _mm512_cmp_ps_mask(x, _mm512_setzero_ps(), _CMP_GE_OQ);
    return _mm512_mask_blend_ps(nonneg, _mm512_sub_ps(_mm512_set1_ps(3.14159265358979f), r), r);
}

}  // namespace

void traverse_level_avx512(const float* nodes, const uint32_t* cur, size_t n, int last, const float* c, float rho,
                           float scale, float eps, float horizon_radius, uint32_t* accepted, size_t* n_accepted,
                           uint32_t* split, size_t* n_split) {
    const __m512 cx = _mm512_set1_ps(c[0]), cy = _mm512_set1_ps(c[1]), cz = _mm512_set1_ps(c[2]);
    const __m512 vrho = _mm512_set1_ps(rho), vscale = _mm512_set1_ps(scale), veps = _mm512_set1_ps(eps);
    const __m512 vhr = _mm512_set1_ps(horizon_radius), zero = _mm512_setzero_ps();
    const __m512 half_pi = _mm512_set1_ps(0.5f * float(3.14159265358979323846));
    size_t na = *n_accepted, ns = *n_split;
    for (size_t k0 = 0; k0 < n; k0 += 16) {
        const size_t m = n - k0 < 16 ? n - k0 : 16;
        const __mmask16 lane = __mmask16(m == 16 ? 0xffffu : (1u << m) - 1u);
        const __m512i idx = _mm512_maskz_loadu_epi32(lane, cur + k0);
        const __m512i off = _mm512_slli_epi32(idx, 4);  // 16 floats a node
        const __m512 px = _mm512_mask_i32gather_ps(zero, lane, off, nodes + kNodePx, 4);
        const __m512 py = _mm512_mask_i32gather_ps(zero, lane, off, nodes + kNodePy, 4);
        const __m512 pz = _mm512_mask_i32gather_ps(zero, lane, off, nodes + kNodePz, 4);
        const __m512 beta = _mm512_mask_i32gather_ps(zero, lane, off, nodes + kNodeRadius, 4);
        const __m512 dot = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(cx, px), _mm512_mul_ps(cy, py)),
                                         _mm512_mul_ps(cz, pz));
        const __m512 d = acos_lanes(dot);
        const __m512 reach = _mm512_sub_ps(_mm512_sub_ps(d, beta), vrho);
        const __mmask16 live = lane & _mm512_cmp_ps_mask(beta, zero, _CMP_GE_OQ) &
                               _mm512_cmp_ps_mask(reach, half_pi, _CMP_LT_OQ);
        // std::max(0, reach) (NaN and -0 give +0): maxps returns its second operand then.
        const __m512 dmin = _mm512_max_ps(reach, zero);
        const __mmask16 near_horizon =
            _mm512_cmp_ps_mask(_mm512_abs_ps(_mm512_sub_ps(d, half_pi)), _mm512_add_ps(beta, vrho), _CMP_LE_OQ);
        // std::max(scale, dmin): scale unless dmin is larger.
        const __m512 reach_scale = _mm512_max_ps(dmin, vscale);
        const __mmask16 small =
            _mm512_cmp_ps_mask(beta, _mm512_mul_ps(veps, reach_scale), _CMP_LE_OQ) &
            __mmask16(~near_horizon | _mm512_cmp_ps_mask(beta, vhr, _CMP_LE_OQ));
        const __mmask16 take = live & (last ? lane : small);
        _mm512_mask_compressstoreu_epi32(accepted + na, take, idx);
        na += size_t(__builtin_popcount(take));
        if (!last) {
            const __mmask16 go_down = live & __mmask16(~take);
            _mm512_mask_compressstoreu_epi32(split + ns, go_down, idx);
            ns += size_t(__builtin_popcount(go_down));
        }
    }
    *n_accepted = na;
    *n_split = ns;
}

void node_fields_avx512(const float* const* nodes, size_t n, float* const* fields, uint32_t* chroma_at,
                        float* const* tinted, size_t* n_chroma) {
    alignas(64) static const float kNoNode[kNodeFloats] = {};
    const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    size_t nc = 0;
    for (size_t k0 = 0; k0 < n; k0 += 16) {
        const size_t m = n - k0 < 16 ? n - k0 : 16;
        const __mmask16 lane = __mmask16(m == 16 ? 0xffffu : (1u << m) - 1u);
        // r[i]: node k0 + i, its 16 floats (a node is one aligned cache line).
        __m512 r[16], t[16];
        for (size_t i = 0; i < 16; ++i) r[i] = _mm512_load_ps(i < m ? nodes[k0 + i] : kNoNode);
        // 4 x 4 blocks within each 128-bit lane: r[4 j + i] then holds
        // field i + 4 l of nodes 4 j .. 4 j + 3 in its lane l.
        for (int j = 0; j < 16; j += 4) {
            const __m512 a0 = _mm512_unpacklo_ps(r[j], r[j + 1]), a1 = _mm512_unpackhi_ps(r[j], r[j + 1]);
            const __m512 a2 = _mm512_unpacklo_ps(r[j + 2], r[j + 3]), a3 = _mm512_unpackhi_ps(r[j + 2], r[j + 3]);
            const __m512d b0 = _mm512_castps_pd(a0), b1 = _mm512_castps_pd(a1), b2 = _mm512_castps_pd(a2),
                          b3 = _mm512_castps_pd(a3);
            r[j] = _mm512_castpd_ps(_mm512_unpacklo_pd(b0, b2));
            r[j + 1] = _mm512_castpd_ps(_mm512_unpackhi_pd(b0, b2));
            r[j + 2] = _mm512_castpd_ps(_mm512_unpacklo_pd(b1, b3));
            r[j + 3] = _mm512_castpd_ps(_mm512_unpackhi_pd(b1, b3));
        }
        // Then the lanes: t[i] and t[8 + i] (i < 4) hold fields i and 8 + i
        // of nodes 0..7 and 8..15; t[4 + i], t[12 + i] fields 4 + i and 12 + i.
        for (int i = 0; i < 4; ++i) {
            t[i] = _mm512_shuffle_f32x4(r[i], r[4 + i], 0x88);
            t[4 + i] = _mm512_shuffle_f32x4(r[i], r[4 + i], 0xdd);
            t[8 + i] = _mm512_shuffle_f32x4(r[8 + i], r[12 + i], 0x88);
            t[12 + i] = _mm512_shuffle_f32x4(r[8 + i], r[12 + i], 0xdd);
        }
        // Field f < 8 from t[f] and t[8 + f]; field 8 + f likewise.
        __m512 row[16];
        for (int f = 0; f < 8; ++f) {
            row[f] = _mm512_shuffle_f32x4(t[f], t[8 + f], 0x88);
            row[8 + f] = _mm512_shuffle_f32x4(t[f], t[8 + f], 0xdd);
        }
        for (int f = 0; f < kFields; ++f) _mm512_mask_storeu_ps(fields[f] + k0, lane, row[f]);
        const __m512i chroma = _mm512_castps_si512(row[kNodeChroma]);
        const __mmask16 tint = lane & _mm512_test_epi32_mask(chroma, chroma);
        if (tint == 0) continue;
        _mm512_mask_compressstoreu_epi32(chroma_at + nc, tint, _mm512_add_epi32(iota, _mm512_set1_epi32(int(k0))));
        // BinNode::chroma_score(c): 10 bits from bit 10 c, over 1023.
        const __m512i bits = _mm512_castps_si512(row[kNodeScores]);
        const __m512i low10 = _mm512_set1_epi32(1023);
        const __m512 inv = _mm512_set1_ps(1.0f / 1023.0f);
        const __m512 score[3] = {
            _mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_and_si512(bits, low10)), inv),
            _mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32(bits, 10), low10)), inv),
            _mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32(bits, 20), low10)), inv)};
        const __m512 rows[kTinted] = {row[kNodePx], row[kNodePy], row[kNodePz], row[kNodeRadius], score[0],
                                      score[1],     score[2],     row[kP0],    row[kP1],        row[kP2]};
        for (int q = 0; q < kTinted; ++q) _mm512_mask_compressstoreu_ps(tinted[q] + nc, tint, rows[q]);
        nc += size_t(__builtin_popcount(tint));
    }
    *n_chroma = nc;
}

}  // namespace kernel
}  // namespace iblbake
