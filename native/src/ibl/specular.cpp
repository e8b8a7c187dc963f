#include "iblbake/ibl/specular.h"

#include <algorithm>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif
#include <cmath>

#include "iblbake/ibl/parallel.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/fast_math.h"
#include "iblbake/math/ggx.h"
#include "iblbake/math/quadrature.h"
#include <cstdio>

namespace iblbake {

std::vector<KernelSample> make_kernel_samples(double roughness, const SpecularQuality& q, int base_face) {
    const double alpha = roughness * roughness;
    const double upper = 1.0 / (1.0 + alpha * alpha);  // n.w = 0 at this u
    const QuadratureRule rule = gauss_legendre(std::max(1, q.rings), 0.0, upper);
    // Level-0 texel solid angle at a face centre is (2 / base)^2.
    const double lod_texel = std::log2(2.0 / base_face);
    std::vector<KernelSample> samples;
    double weight_sum = 0.0;
    for (size_t i = 0; i < rule.nodes.size(); ++i) {
        const double u = rule.nodes[i];
        const double cos2 = ggx::sample_cos2(alpha, u), sin2 = ggx::sample_sin2(alpha, u);
        const double c = cos2 - sin2;                       // n.w = cos(2 theta_h)
        const double sin_w = 2.0 * std::sqrt(cos2 * sin2);  // sin(2 theta_h)
        // Cell sizes: dh = du dphi / (2 pi D cos_h), dw = 4 cos_h dh, so the
        // ring's solid angle is 4 g_i / D.
        const double ring = 4.0 * rule.weights[i] / ggx::D(alpha, cos2, sin2);
        const double circumference = 2.0 * kPi * sin_w;
        const int nphi = std::clamp(int(std::lround(circumference * circumference / ring)), q.min_phi, q.max_phi);
        const double cell = ring / nphi;
        const double lod = 0.5 * std::log2(cell) - lod_texel + q.lod_bias;
        const double offset = std::fmod(0.6180339887498949 * double(i), 1.0);  // rotate rings apart
        for (int k = 0; k < nphi; ++k) {
            const double phi = 2.0 * kPi * (k + offset) / nphi;
            KernelSample s;
            s.t = float(sin_w * std::cos(phi));
            s.b = float(sin_w * std::sin(phi));
            s.n = float(c);
            s.weight = float(rule.weights[i] * c / nphi);
            s.lod_base = float(lod);
            weight_sum += s.weight;
            samples.push_back(s);
        }
    }
    for (auto& s : samples) s.weight = float(s.weight / weight_sum);
    return samples;
}

void specular_mirror(Cubemap& dst, ImageView latlong) {
    const int n = dst.size, w = latlong.width, h = latlong.height;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        // latlong_bilinear for a whole row: the lat-long coordinates first,
        // in one loop that vectorises (atan2_vec), then the lookups.
        thread_local std::vector<double> fx, fy;
        fx.resize(n);
        fy.resize(n);
        const FaceFrame& fr = kFaceFrames[f];
        const double b = 2.0 * (j + 0.5) / n - 1.0;
        for (int i = 0; i < n; ++i) {
            const double a = 2.0 * (i + 0.5) / n - 1.0;
            const double ex = fr.ma.x + fr.s.x * a + fr.t.x * b, ey = fr.ma.y + fr.s.y * a + fr.t.y * b,
                         ez = fr.ma.z + fr.s.z * a + fr.t.z * b;
            // Blender (x, y, z) = (ex, -ez, ey); the length cancels in both angles.
            const double bx = ex, by = -ez, bz = ey;
            const double u = 0.5 - atan2_vec(by, bx) * (0.5 / kPi);
            const double v = 0.5 + atan2_vec(bz, std::sqrt(bx * bx + by * by)) * (1.0 / kPi);
            fx[i] = (u - std::floor(u)) * w - 0.5;
            fy[i] = (1.0 - v) * h - 0.5;
        }
        for (int i = 0; i < n; ++i) {
            const double x0f = std::floor(fx[i]), y0f = std::floor(fy[i]);
            const double tx = fx[i] - x0f, ty = fy[i] - y0f;
            int x0 = int(x0f) % w;
            if (x0 < 0) x0 += w;
            const int x1 = (x0 + 1) % w;
            const int y0 = std::clamp(int(y0f), 0, h - 1), y1 = std::clamp(int(y0f) + 1, 0, h - 1);
            const float *pa = latlong.at(x0, y0), *pb = latlong.at(x1, y0), *pc = latlong.at(x0, y1),
                        *pd = latlong.at(x1, y1);
            float* o = dst.at(f, i, j);
            for (int k = 0; k < 3; ++k) {
                const double top = pa[k] + (pb[k] - pa[k]) * tx;
                const double bottom = pc[k] + (pd[k] - pc[k]) * tx;
                o[k] = float(top + (bottom - top) * ty);
            }
        }
    });
}

namespace {

// Exact kernel sum of the hot points for one direction, divided by Z(alpha).
void hot_term(const std::vector<RadiancePoint>& hot, const Vec3& n, float alpha, float inv_z, float out[3]) {
    const float a2 = alpha * alpha, norm = 4.0f * a2 / float(kPi);
    float acc[3] = {0, 0, 0};
    for (const RadiancePoint& p : hot) {
        const float dx = n.x - p.dir[0], dy = n.y - p.dir[1], dz = n.z - p.dir[2];
        const float omc = 0.5f * (dx * dx + dy * dy + dz * dz);  // 1 - n.w without cancellation
        const float k = norm * ggx::prefilter_kernel_shape(a2, omc);
        for (int ch = 0; ch < 3; ++ch) acc[ch] += k * p.power[ch];
    }
    for (int ch = 0; ch < 3; ++ch) out[ch] = acc[ch] * inv_z;
}

}  // namespace

size_t specular_prefilter(Cubemap& dst, const CubePyramid& rest, const std::vector<RadiancePoint>& hot,
                        double roughness, const SpecularQuality& q) {
    const std::vector<KernelSample> samples = make_kernel_samples(roughness, q, rest.base_size());
    const double alpha = roughness * roughness;
    const float inv_z = float(1.0 / ggx::prefilter_normalizer(alpha));
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) {
            const Vec3 nn(texel_direction(f, i, j, n));
            Vec3 t, b;
            orthonormal_basis(nn, t, b);
            float acc[3] = {0, 0, 0};
            for (const KernelSample& s : samples) {
                const Vec3 w = t * s.t + b * s.b + nn * s.n;
                // Texel solid angle grows as |w_major|^-3 toward face centres.
                const float ma = std::max(std::fabs(w.x), std::max(std::fabs(w.y), std::fabs(w.z)));
                const float lod = s.lod_base - 1.5f * std::log2(ma);
                float v[3];
                rest.trilinear(w, lod, v);
                for (int k = 0; k < 3; ++k) acc[k] += s.weight * v[k];
            }
            float h[3] = {0, 0, 0};
            if (!hot.empty()) hot_term(hot, nn, float(alpha), inv_z, h);
            float* o = dst.at(f, i, j);
            for (int k = 0; k < 3; ++k) o[k] = acc[k] + h[k];
        }
    });
    return samples.size();
}

namespace {

// The bins a tile uses, as structure-of-arrays: unit centroid p, g = 1 - |m|,
// power per channel, covariance (xx, yy, zz, xy, xz, yz).
enum Field { kPx, kPy, kPz, kG, kP0, kP1, kP2, kCxx, kCyy, kCzz, kCxy, kCxz, kCyz, kFields };

constexpr size_t kLanes = 16;  // independent partial sums: the loop vectorises, the order stays fixed

// sum_b power_b E_b[K(n.w)] over `count` bins (a multiple of kLanes), K the
// GGX prefilter kernel up to its constant factor 4 a^2 / pi, by a rule from
// the bin's moments: with X = n.w over the bin's radiance, its mean
// mu = n.m (exact) and variance var = n^T C n (exact),
//   E[k(X)] = k(mu) + k''(mu) var / 2 + k''''(mu) E[(X - mu)^4] / 24 + ...,
// k(c) = c / t^2, t = (1 - c)(1 - a^2) + 2 a^2, s = 1 - a^2, so with
// v = var s / t,
//   E[k(X)] = t^-2 [c + v (2 + 3 c s / t) + kurt v^2 (4 s / t + 5 c s^2 / t^2)],
// the fourth moment taken as kurt var^2. The kernel's tail is convex at
// every order, so a rule that stops at the variance comes out low (about
// -0.3 % at eps 0.4 on a constant world); kurt = 1.5, below any bin of
// uniform radiance (1.8 to 2.4 for a rectangle), takes most of that back
// (constant world within 0.04 %) and overshoots only for bins whose
// radiance sits in two spots (kurtosis near 1). Third moments (skew) are
// not kept. Float lanes within blocks, double across.
constexpr float kKurtosis = 1.5f;

// With u = s / t, v = var u, cu = c u:
//   E[k] = t^-2 [c + v (2 + 3 cu + kurt v u (4 + 5 cu))].
void kernel_sums(const float* const* f, size_t count, float a2, const Vec3& n, double num[3]) {
    num[0] = num[1] = num[2] = 0.0;
    const float s = 1.0f - a2, twoa2 = 2.0f * a2;
    const float nxx = n.x * n.x, nyy = n.y * n.y, nzz = n.z * n.z;
    const float nxy = 2.0f * n.x * n.y, nxz = 2.0f * n.x * n.z, nyz = 2.0f * n.y * n.z;
    constexpr size_t kBlock = 512;
    for (size_t b = 0; b < count; b += kBlock) {
        const size_t e = std::min(count, b + kBlock);
        float t0 = 0, t1 = 0, t2 = 0;
#if defined(__AVX512F__)
        // The same sum on 16 lanes, the reciprocal by rcp14 and one Newton
        // step (within an ulp or two of the division).
        __m512 a0 = _mm512_setzero_ps(), a1 = _mm512_setzero_ps(), a2v = _mm512_setzero_ps();
        const __m512 vnx = _mm512_set1_ps(n.x), vny = _mm512_set1_ps(n.y), vnz = _mm512_set1_ps(n.z);
        const __m512 one = _mm512_set1_ps(1.0f), half = _mm512_set1_ps(0.5f), two = _mm512_set1_ps(2.0f);
        const __m512 vs = _mm512_set1_ps(s), vt2 = _mm512_set1_ps(twoa2), kurt = _mm512_set1_ps(kKurtosis);
        const __m512 three = _mm512_set1_ps(3.0f), four = _mm512_set1_ps(4.0f), five = _mm512_set1_ps(5.0f);
        for (size_t p = b; p < e; p += kLanes) {
            const __m512 dx = _mm512_sub_ps(vnx, _mm512_loadu_ps(f[kPx] + p));
            const __m512 dy = _mm512_sub_ps(vny, _mm512_loadu_ps(f[kPy] + p));
            const __m512 dz = _mm512_sub_ps(vnz, _mm512_loadu_ps(f[kPz] + p));
            const __m512 d2 = _mm512_fmadd_ps(dz, dz, _mm512_fmadd_ps(dy, dy, _mm512_mul_ps(dx, dx)));
            const __m512 g = _mm512_loadu_ps(f[kG] + p);
            const __m512 omc = _mm512_fmadd_ps(_mm512_mul_ps(_mm512_sub_ps(one, g), half), d2, g);
            const __m512 c = _mm512_sub_ps(one, omc);
            __m512 var = _mm512_mul_ps(_mm512_loadu_ps(f[kCxx] + p), _mm512_set1_ps(nxx));
            var = _mm512_fmadd_ps(_mm512_loadu_ps(f[kCyy] + p), _mm512_set1_ps(nyy), var);
            var = _mm512_fmadd_ps(_mm512_loadu_ps(f[kCzz] + p), _mm512_set1_ps(nzz), var);
            var = _mm512_fmadd_ps(_mm512_loadu_ps(f[kCxy] + p), _mm512_set1_ps(nxy), var);
            var = _mm512_fmadd_ps(_mm512_loadu_ps(f[kCxz] + p), _mm512_set1_ps(nxz), var);
            var = _mm512_fmadd_ps(_mm512_loadu_ps(f[kCyz] + p), _mm512_set1_ps(nyz), var);
            const __m512 t = _mm512_fmadd_ps(vs, omc, vt2);
            __m512 it = _mm512_maskz_rcp14_ps(0xffff, t);  // (rcp14_ps trips -Wmaybe-uninitialized on GCC 12)
            it = _mm512_mul_ps(it, _mm512_fnmadd_ps(t, it, two));
            const __m512 u = _mm512_mul_ps(vs, it), v = _mm512_mul_ps(var, u), cu = _mm512_mul_ps(c, u);
            const __m512 hi = _mm512_mul_ps(_mm512_mul_ps(kurt, _mm512_mul_ps(v, u)), _mm512_fmadd_ps(five, cu, four));
            const __m512 inner = _mm512_add_ps(_mm512_fmadd_ps(three, cu, two), hi);
            const __m512 k = _mm512_mul_ps(_mm512_mul_ps(it, it), _mm512_fmadd_ps(v, inner, c));
            const __mmask16 lit = _mm512_cmp_ps_mask(c, _mm512_setzero_ps(), _CMP_GT_OQ);
            a0 = _mm512_mask3_fmadd_ps(k, _mm512_loadu_ps(f[kP0] + p), a0, lit);
            a1 = _mm512_mask3_fmadd_ps(k, _mm512_loadu_ps(f[kP1] + p), a1, lit);
            a2v = _mm512_mask3_fmadd_ps(k, _mm512_loadu_ps(f[kP2] + p), a2v, lit);
        }
        alignas(64) float s0[kLanes], s1[kLanes], s2[kLanes];
        _mm512_store_ps(s0, a0);
        _mm512_store_ps(s1, a1);
        _mm512_store_ps(s2, a2v);
#else
        float s0[kLanes] = {}, s1[kLanes] = {}, s2[kLanes] = {};
        for (size_t p = b; p < e; p += kLanes)
            for (size_t l = 0; l < kLanes; ++l) {
                const size_t q = p + l;
                const float dx = n.x - f[kPx][q], dy = n.y - f[kPy][q], dz = n.z - f[kPz][q];
                const float g = f[kG][q];
                const float omc = g + (1.0f - g) * 0.5f * (dx * dx + dy * dy + dz * dz);  // 1 - n.m
                const float c = 1.0f - omc;
                const float var = f[kCxx][q] * nxx + f[kCyy][q] * nyy + f[kCzz][q] * nzz + f[kCxy][q] * nxy +
                                  f[kCxz][q] * nxz + f[kCyz][q] * nyz;
                const float it = 1.0f / (s * omc + twoa2);
                const float u = s * it, v = var * u, cu = c * u;
                const float k = it * it * (c + v * (2.0f + 3.0f * cu + kKurtosis * v * u * (4.0f + 5.0f * cu)));
                const float kv = c > 0.0f ? k : 0.0f;
                s0[l] += kv * f[kP0][q];
                s1[l] += kv * f[kP1][q];
                s2[l] += kv * f[kP2][q];
            }
#endif
        for (size_t l = 0; l < kLanes; ++l) {
            t0 += s0[l];
            t1 += s1[l];
            t2 += s2[l];
        }
        num[0] += t0;
        num[1] += t1;
        num[2] += t2;
    }
}

}  // namespace

double hierarchical_level_eps(const HierarchicalQuality& q, int face) {
    return q.eps * std::clamp(std::sqrt(face / 64.0), 0.5, 1.0);
}

double hierarchical_horizon_radius(double roughness, int face, const HierarchicalQuality& q) {
    const double alpha = roughness * roughness, a2 = alpha * alpha;
    const double d45 = 4.0 * a2 / (kPi * (1.0 + a2) * (1.0 + a2));
    return std::min(kPi, hierarchical_level_eps(q, face) * q.horizon / std::sqrt(d45 / ggx::prefilter_normalizer(alpha)));
}

double specular_hierarchical(Cubemap& dst, const BinTree& tree, double roughness, const HierarchicalQuality& q) {
    const float alpha = float(roughness * roughness), a2 = alpha * alpha;
    // The exact normaliser: integral of K over the sphere, in closed form, in
    // the units kernel_sums uses (without the factor 4 a^2 / pi).
    const double a2d = roughness * roughness * roughness * roughness;
    const double inv_z = 4.0 * a2d / (kPi * ggx::prefilter_normalizer(roughness * roughness));
    // The lobe's angular length scale in w: 2 alpha for narrow lobes, about
    // one radian (the cosine's) as alpha -> 1.
    const float scale = 2.0f * alpha / (1.0f + alpha);
    const float eps = float(hierarchical_level_eps(q, dst.size));
    // K = D(h) max(0, n.w) has a kink at n's horizon with slope D(45 deg),
    // where no rule from a bin's moments is exact (a bin across it loses the
    // part of its radiance behind; by Jensen's inequality every such rule
    // comes out low). Relative to the kernel's integral Z that slope sets how
    // small bins that may straddle a horizon must be, in proportion to eps:
    // radius <= eps horizon / sqrt(D45 / Z).
    const float horizon_radius = float(hierarchical_horizon_radius(roughness, dst.size, q));
    // Tiles of at most a quarter of the face: a tile as wide as the face
    // would see every bin as near and take them all at the finest level.
    const int n = dst.size, T = std::max(1, std::min(q.tile, n / 4));
    const int tiles_per_row = (n + T - 1) / T, tiles = 6 * tiles_per_row * tiles_per_row;
    const int top = int(tree.levels.size()) - 1;
    std::vector<double> used(tiles, 0.0);
    parallel_for(0, tiles, [&](int tile) {
        const int face = tile / (tiles_per_row * tiles_per_row);
        const int ty = (tile / tiles_per_row) % tiles_per_row, tx = tile % tiles_per_row;
        const int i0 = tx * T, j0 = ty * T, i1 = std::min(n, i0 + T), j1 = std::min(n, j0 + T);
        // The tile: texel directions, centre, angular radius.
        std::vector<Vec3> dirs;
        Vec3d sum{0, 0, 0};
        for (int j = j0; j < j1; ++j)
            for (int i = i0; i < i1; ++i) {
                const Vec3d d = texel_direction(face, i, j, n);
                dirs.emplace_back(d);
                sum += d;
            }
        const Vec3 c(normalize(sum));
        float min_cos = 1.0f;
        for (const Vec3& d : dirs) min_cos = std::min(min_cos, dot(c, d));
        const float rho = std::acos(std::clamp(min_cos, -1.0f, 1.0f)) + 1e-6f;

        // Traverse, one level at a time from the coarsest: accept a bin whole
        // when it is small against the kernel's length scale at its least
        // distance from the tile, else visit its four children next.
        thread_local std::vector<float> acc[kFields];
        thread_local std::vector<uint32_t> cur, next;
        thread_local std::vector<const BinNode*> accepted;
        cur.clear();
        accepted.clear();
        for (int b = 0; b < tree.levels[top].w * tree.levels[top].h; ++b) cur.push_back(uint32_t(b));
        for (int lvl = top; lvl >= 0 && !cur.empty(); --lvl) {
            const BinLevel& L = tree.levels[lvl];
            const BinNode* nodes = L.nodes.data();
            next.clear();
            for (const uint32_t b : cur) {
                const BinNode& nd = nodes[b];
                const float beta = nd.radius;
                if (beta < 0.0f) continue;  // no radiance
                const float d = fast_acos(c.x * nd.px + c.y * nd.py + c.z * nd.pz);
                if (d - beta - rho >= 0.5f * float(kPi)) continue;  // behind every texel's horizon
                const float dmin = std::max(0.0f, d - beta - rho);
                const bool near_horizon = std::fabs(d - 0.5f * float(kPi)) <= beta + rho;
                const bool small = beta <= eps * std::max(scale, dmin) && (!near_horizon || beta <= horizon_radius);
                if (lvl == 0 || small) {
                    accepted.push_back(&nd);
                } else {
                    const uint32_t y = b / uint32_t(L.w), x = b - y * uint32_t(L.w), w2 = 2 * uint32_t(L.w);
                    const uint32_t c0 = 2 * y * w2 + 2 * x;
                    next.insert(next.end(), {c0, c0 + 1, c0 + w2, c0 + w2 + 1});
                }
            }
            std::swap(cur, next);
        }
        // The accepted bins' fields, structure-of-arrays, padded to whole
        // lanes with bins of no power.
        const size_t count = accepted.size();
        const size_t padded = (count + kLanes - 1) / kLanes * kLanes;
        for (auto& a : acc) a.resize(padded);
        for (size_t i = 0; i < count; ++i) {
            const BinNode& nd = *accepted[i];
            acc[kPx][i] = nd.px, acc[kPy][i] = nd.py, acc[kPz][i] = nd.pz, acc[kG][i] = nd.g;
            for (int ch = 0; ch < 3; ++ch) acc[kP0 + ch][i] = nd.power[ch];
            for (int k = 0; k < 6; ++k) acc[kCxx + k][i] = nd.cov[k];
        }
        for (auto& a : acc) std::fill(a.begin() + count, a.end(), 0.0f);
        used[tile] = double(count);
        const float* fields[kFields];
        for (int k = 0; k < kFields; ++k) fields[k] = acc[k].data();
        size_t k = 0;
        for (int j = j0; j < j1; ++j)
            for (int i = i0; i < i1; ++i, ++k) {
                double num[3];
                kernel_sums(fields, padded, a2, dirs[k], num);

                float* o = dst.at(face, i, j);
                for (int ch = 0; ch < 3; ++ch) o[ch] = float(num[ch] * inv_z);
            }
    });
    double total = 0.0;
    for (double u : used) total += u;
    return total / tiles;
}

}  // namespace iblbake
