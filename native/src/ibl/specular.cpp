#include "iblbake/ibl/specular.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "iblbake/ibl/parallel.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/fast_math.h"
#include "iblbake/math/ggx.h"
#include "iblbake/math/quadrature.h"

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
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) latlong_bilinear(latlong, texel_direction(f, i, j, n), dst.at(f, i, j));
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

// The bins a tile uses, as structure-of-arrays: power centroids p, solid-angle
// centroids c, power per channel, solid angle.
struct BinSoA {
    const float *px, *py, *pz, *cx, *cy, *cz, *p0, *p1, *p2, *om;
};

constexpr size_t kLanes = 16;  // independent partial sums: the loop vectorises, the order stays fixed

// sum_b K(n.p_b) power_b and (kWithDen) sum_b K(n.c_b) omega_b over `count`
// bins (a multiple of kLanes), K the GGX prefilter kernel up to its constant
// factor (4 a^2 / pi cancels in the ratio). Float lanes within blocks, double
// across.
template <bool kWithDen>
void kernel_sums(const BinSoA& b, size_t count, float a2, const Vec3& n, double num[3], double& den) {
    num[0] = num[1] = num[2] = den = 0.0;
    constexpr size_t kBlock = 512;
    for (size_t s = 0; s < count; s += kBlock) {
        const size_t e = std::min(count, s + kBlock);
        float s0[kLanes] = {}, s1[kLanes] = {}, s2[kLanes] = {}, sw[kLanes] = {};
        for (size_t p = s; p < e; p += kLanes)
            for (size_t l = 0; l < kLanes; ++l) {
                const size_t q = p + l;
                const float dx = n.x - b.px[q], dy = n.y - b.py[q], dz = n.z - b.pz[q];
                // The numerator's kernel is computed alike in both variants, so
                // a bake with a cached normaliser gives the same bits.
                const float kp = ggx::prefilter_kernel_shape(a2, 0.5f * (dx * dx + dy * dy + dz * dz));
                if constexpr (kWithDen) {
                    const float ex = n.x - b.cx[q], ey = n.y - b.cy[q], ez = n.z - b.cz[q];
                    sw[l] += ggx::prefilter_kernel_shape(a2, 0.5f * (ex * ex + ey * ey + ez * ez)) * b.om[q];
                }
                s0[l] += kp * b.p0[q];
                s1[l] += kp * b.p1[q];
                s2[l] += kp * b.p2[q];
            }
        float t0 = 0, t1 = 0, t2 = 0, tw = 0;
        for (size_t l = 0; l < kLanes; ++l) {
            t0 += s0[l];
            t1 += s1[l];
            t2 += s2[l];
            tw += sw[l];
        }
        num[0] += t0;
        num[1] += t1;
        num[2] += t2;
        den += tw;
    }
}

// What a traversal needs of a lobe: its angular length scale in w (2 alpha
// for narrow lobes, about one radian, the cosine's, as alpha -> 1) and the
// length scale of its kink at n's horizon: K = D(h) max(0, n.w) has slope
// D(45 deg) there, and relative to the kernel's integral Z that slope sets how
// small bins that straddle a horizon must be: 0.1 / sqrt(D45 / Z).
struct LobeScales {
    float scale, horizon_scale;
};
LobeScales lobe_scales(double roughness) {
    const float alpha = float(roughness * roughness), a2 = alpha * alpha;
    const double d45 = 4.0 * a2 / (kPi * (1.0 + a2) * (1.0 + a2));
    return {2.0f * alpha / (1.0f + alpha),
            float(std::min(kPi, 0.1 / std::sqrt(d45 / ggx::prefilter_normalizer(alpha))))};
}

// A tile of output texels: its texels' directions, centre and angular radius.
struct Tile {
    int face, i0, j0, i1, j1;
    std::vector<Vec3> dirs;
    Vec3 c;
    float rho;
};
Tile make_tile(int tile, int n, int T) {
    const int tiles_per_row = (n + T - 1) / T;
    Tile t;
    t.face = tile / (tiles_per_row * tiles_per_row);
    const int ty = (tile / tiles_per_row) % tiles_per_row, tx = tile % tiles_per_row;
    t.i0 = tx * T;
    t.j0 = ty * T;
    t.i1 = std::min(n, t.i0 + T);
    t.j1 = std::min(n, t.j0 + T);
    Vec3d sum{0, 0, 0};
    for (int j = t.j0; j < t.j1; ++j)
        for (int i = t.i0; i < t.i1; ++i) {
            const Vec3d d = texel_direction(t.face, i, j, n);
            t.dirs.emplace_back(d);
            sum += d;
        }
    t.c = Vec3(normalize(sum));
    float min_cos = 1.0f;
    for (const Vec3& d : t.dirs) min_cos = std::min(min_cos, dot(t.c, d));
    t.rho = std::acos(std::clamp(min_cos, -1.0f, 1.0f)) + 1e-6f;
    return t;
}

// Traverse the tree for a tile: accept a bin whole when it is small against
// the kernel's length scale at its least distance from the tile, gathering
// its power centroid and power (and, with `centroids`, its solid-angle
// centroid and solid angle) into acc, padded to whole lanes with bins of no
// power and no solid angle. Returns the number of bins accepted.
size_t gather_bins(const BinTree& tree, const Tile& t, const LobeScales& ls, float eps, bool centroids,
                   std::vector<float> (&acc)[10]) {
    thread_local std::vector<int> stack;
    thread_local std::vector<uint32_t> accepted;  // (level << 26) | bin index, in traversal order
    stack.clear();
    accepted.clear();
    const int top = int(tree.levels.size()) - 1;
    const BinLevel& coarsest = tree.levels[top];
    for (int y = 0; y < coarsest.h; ++y)
        for (int x = 0; x < coarsest.w; ++x) stack.push_back((top << 26) | (y << 13) | x);
    const Vec3& c = t.c;
    const float rho = t.rho;
    while (!stack.empty()) {
        const int code = stack.back();
        stack.pop_back();
        const int lvl = code >> 26, y = (code >> 13) & 8191, x = code & 8191;
        const BinLevel& L = tree.levels[lvl];
        const size_t b = L.index(x, y);
        if (!(L.omega[b] > 0.0f)) continue;
        const float cosd = c.x * L.cx[b] + c.y * L.cy[b] + c.z * L.cz[b];
        const float d = fast_acos(cosd);
        const float beta = L.radius[b];
        if (d - beta - rho >= 0.5f * float(kPi)) continue;  // behind every texel's horizon
        const float dmin = std::max(0.0f, d - beta - rho);
        const bool near_horizon = std::fabs(d - 0.5f * float(kPi)) <= beta + rho;
        const float length_scale = near_horizon ? std::min(ls.horizon_scale, std::max(ls.scale, dmin))
                                                : std::max(ls.scale, dmin);
        if (lvl == 0 || beta <= eps * length_scale) {
            accepted.push_back((uint32_t(lvl) << 26) | uint32_t(b));
        } else {
            const int cl = lvl - 1;
            for (int dy = 0; dy < 2; ++dy)
                for (int dx = 0; dx < 2; ++dx) stack.push_back((cl << 26) | ((2 * y + dy) << 13) | (2 * x + dx));
        }
    }
    // The accepted bins as structure-of-arrays, padded to whole lanes with
    // bins of no power and no solid angle (the solid-angle centroids serve
    // the denominator alone).
    const size_t count = accepted.size();
    const size_t padded = (count + kLanes - 1) / kLanes * kLanes;
    for (int a : {0, 1, 2, 6, 7, 8}) acc[a].assign(padded, 0.0f);
    for (int a : {3, 4, 5, 9}) acc[a].assign(centroids ? padded : 0, 0.0f);
    for (size_t k = 0; k < count; ++k) {
        const BinLevel& L = tree.levels[accepted[k] >> 26];
        const size_t b = accepted[k] & ((1u << 26) - 1);
        acc[0][k] = L.px[b]; acc[1][k] = L.py[b]; acc[2][k] = L.pz[b];
        acc[6][k] = L.power[0][b]; acc[7][k] = L.power[1][b]; acc[8][k] = L.power[2][b];
    }
    if (centroids)
        for (size_t k = 0; k < count; ++k) {
            const BinLevel& L = tree.levels[accepted[k] >> 26];
            const size_t b = accepted[k] & ((1u << 26) - 1);
            acc[3][k] = L.cx[b]; acc[4][k] = L.cy[b]; acc[5][k] = L.cz[b];
            acc[9][k] = L.omega[b];
        }
    return count;
}

BinSoA soa(std::vector<float> (&acc)[10]) {
    return {acc[0].data(), acc[1].data(), acc[2].data(), acc[3].data(), acc[4].data(),
            acc[5].data(), acc[6].data(), acc[7].data(), acc[8].data(), acc[9].data()};
}

// kernel_sums for K lobes at once (1 <= K <= 3) on the same bins: the
// distance is computed once, and one division per bin serves every lobe:
// K_k = c / t_k^2 = (c / prod_j t_j^2) * prod_{j != k} t_j^2. The caller keeps
// prod_j (2 a2_j)^2 (its smallest value) far above float's least normal.
// The kernels of up to four lobes (a2s_j = a2_j / s) at one half squared distance x,
// each up to the constant factor s^2 (which cancels in the ratio of sums):
// with u_k = t_k / s, one division for all, K_k s^2 = (c / prod_j u_j^2) *
// prod_{j != k} u_j^2. s = 2 min_k a2_k, the least t, keeps every u >= 1.
template <int K>
inline void group_kernels(float x, const float (&a2s)[4], float inv_s, float (&k)[4]) {
    const float c = 1.0f - x, two_minus_x = 1.0f + c, xs = x * inv_s;
    float q[4];
    for (int j = 0; j < K; ++j) {
        const float u = xs + a2s[j] * two_minus_x;  // (x + a2_j (2 - x)) / s
        q[j] = u * u;
    }
    if constexpr (K == 1) {
        k[0] = c > 0.0f ? c / q[0] : 0.0f;
    } else if constexpr (K == 2) {
        const float inv = c > 0.0f ? c / (q[0] * q[1]) : 0.0f;
        k[0] = inv * q[1];
        k[1] = inv * q[0];
    } else if constexpr (K == 3) {
        const float q01 = q[0] * q[1];
        const float inv = c > 0.0f ? c / (q01 * q[2]) : 0.0f;
        k[0] = inv * (q[1] * q[2]);
        k[1] = inv * (q[0] * q[2]);
        k[2] = inv * q01;
    } else {
        const float q01 = q[0] * q[1], q23 = q[2] * q[3];
        const float inv = c > 0.0f ? c / (q01 * q23) : 0.0f;
        const float i01 = inv * q01, i23 = inv * q23;
        k[0] = i23 * q[1];
        k[1] = i23 * q[0];
        k[2] = i01 * q[3];
        k[3] = i01 * q[2];
    }
}

// kernel_sums for K lobes at once (1 <= K <= 4) on the same bins: the
// distance is computed once and one division per bin serves every lobe.
// (Accumulators named one by one: the lane loop then vectorises as
// kernel_sums' does.)
template <int K, bool kWithDen>
void kernel_sums_group(const BinSoA& b, size_t count, const float (&a2)[4], float inv_s, const Vec3& n,
                       double num[4][3], double den[4]) {
    for (int k = 0; k < 4; ++k) num[k][0] = num[k][1] = num[k][2] = den[k] = 0.0;
    constexpr size_t kBlock = 512;
    for (size_t s = 0; s < count; s += kBlock) {
        const size_t e = std::min(count, s + kBlock);
        float a0[kLanes] = {}, a1[kLanes] = {}, a2s[kLanes] = {}, w0[kLanes] = {};
        float b0[kLanes] = {}, b1[kLanes] = {}, b2[kLanes] = {}, w1[kLanes] = {};
        float c0[kLanes] = {}, c1[kLanes] = {}, c2[kLanes] = {}, w2[kLanes] = {};
        float d0[kLanes] = {}, d1[kLanes] = {}, d2[kLanes] = {}, w3[kLanes] = {};
        for (size_t p = s; p < e; p += kLanes)
            for (size_t l = 0; l < kLanes; ++l) {
                const size_t q = p + l;
                const float dx = n.x - b.px[q], dy = n.y - b.py[q], dz = n.z - b.pz[q];
                float k[4];
                group_kernels<K>(0.5f * (dx * dx + dy * dy + dz * dz), a2, inv_s, k);
                const float p0 = b.p0[q], p1 = b.p1[q], p2 = b.p2[q];
                a0[l] += k[0] * p0; a1[l] += k[0] * p1; a2s[l] += k[0] * p2;
                if constexpr (K >= 2) { b0[l] += k[1] * p0; b1[l] += k[1] * p1; b2[l] += k[1] * p2; }
                if constexpr (K >= 3) { c0[l] += k[2] * p0; c1[l] += k[2] * p1; c2[l] += k[2] * p2; }
                if constexpr (K >= 4) { d0[l] += k[3] * p0; d1[l] += k[3] * p1; d2[l] += k[3] * p2; }
                if constexpr (kWithDen) {
                    const float ex = n.x - b.cx[q], ey = n.y - b.cy[q], ez = n.z - b.cz[q];
                    float m[4];
                    group_kernels<K>(0.5f * (ex * ex + ey * ey + ez * ez), a2, inv_s, m);
                    const float om = b.om[q];
                    w0[l] += m[0] * om;
                    if constexpr (K >= 2) w1[l] += m[1] * om;
                    if constexpr (K >= 3) w2[l] += m[2] * om;
                    if constexpr (K >= 4) w3[l] += m[3] * om;
                }
            }
        const float* sums[4][4] = {{a0, a1, a2s, w0}, {b0, b1, b2, w1}, {c0, c1, c2, w2}, {d0, d1, d2, w3}};
        for (int k = 0; k < K; ++k) {
            float t[4] = {0, 0, 0, 0};
            for (int m = 0; m < 4; ++m)
                for (size_t l = 0; l < kLanes; ++l) t[m] += sums[k][m][l];
            for (int ch = 0; ch < 3; ++ch) num[k][ch] += t[ch];
            den[k] += t[3];
        }
    }
}

template <int K>
void group_sums(bool with_den, const BinSoA& b, size_t count, const float (&a2)[4], float inv_s, const Vec3& n,
                double num[4][3], double den[4]) {
    if (with_den) kernel_sums_group<K, true>(b, count, a2, inv_s, n, num, den);
    else kernel_sums_group<K, false>(b, count, a2, inv_s, n, num, den);
}

}  // namespace

double specular_hierarchical(Cubemap& dst, const BinTree& tree, double roughness, const HierarchicalQuality& q,
                             std::vector<float>* normaliser) {
    const size_t texels = size_t(6) * dst.size * dst.size;
    const bool given = normaliser && normaliser->size() == texels;
    if (normaliser && !given) normaliser->assign(texels, 0.0f);
    const float alpha = float(roughness * roughness), a2 = alpha * alpha;
    const LobeScales ls = lobe_scales(roughness);
    const float eps = float(q.eps);
    const int n = dst.size, T = std::max(1, std::min(q.tile, n));
    const int tiles_per_row = (n + T - 1) / T, tiles = 6 * tiles_per_row * tiles_per_row;
    std::vector<double> used(tiles, 0.0);
    parallel_for(0, tiles, [&](int tile) {
        const Tile t = make_tile(tile, n, T);
        thread_local std::vector<float> acc[10];
        used[tile] = double(gather_bins(tree, t, ls, eps, !given, acc));
        const size_t padded = acc[0].size();
        const BinSoA bins = soa(acc);
        size_t k = 0;
        for (int j = t.j0; j < t.j1; ++j)
            for (int i = t.i0; i < t.i1; ++i, ++k) {
                double num[3], den;
                const size_t idx = (size_t(t.face) * n + j) * n + i;
                // The denominator is geometry alone (bin centroids and solid
                // angles, the same bins for any source): a cached one is used
                // as is, a computed one is rounded to float as the cache keeps
                // it, so warm and cold bakes give the same bits.
                if (given) {
                    kernel_sums<false>(bins, padded, a2, t.dirs[k], num, den);
                    den = (*normaliser)[idx];
                } else {
                    kernel_sums<true>(bins, padded, a2, t.dirs[k], num, den);
                    den = double(float(den));
                    if (normaliser) (*normaliser)[idx] = float(den);
                }
                float* o = dst.at(t.face, i, j);
                for (int ch = 0; ch < 3; ++ch) o[ch] = den > 0.0 ? float(num[ch] / den) : 0.0f;
            }
    });
    double total = 0.0;
    for (double u : used) total += u;
    return total / tiles;
}

// The scaled factors u_k = t_k / s lie in [1, (1 + 2 a2) / s] where the kernel
// is not 0 (c > 0): their product over the group must stay finite in float.
bool specular_group_safe(const std::vector<double>& roughness) {
    if (roughness.empty()) return true;
    if (roughness.size() > 4) return false;
    double a2_min = 1.0;
    for (double r : roughness) {
        if (!(r > 0.0) || r > 1.0) return false;
        const double alpha = float(r * r);
        a2_min = std::min(a2_min, alpha * alpha);
    }
    const double s = 2.0 * a2_min, u_max = (1.0 + 2.0) / s;
    return std::pow(u_max * u_max, double(roughness.size())) < 1e36;
}

double specular_hierarchical_group(std::vector<SpecularGroupTarget>& targets, const BinTree& tree,
                                   const HierarchicalQuality& q) {
    if (targets.empty()) return 0.0;
    const int n = targets[0].dst->size;
    std::vector<double> rough;
    for (const SpecularGroupTarget& g : targets) {
        if (g.dst->size != n) throw std::invalid_argument("a specular group needs one face size");
        if (!(g.roughness > 0.0)) throw std::invalid_argument("a specular group needs roughness > 0");
        rough.push_back(g.roughness);
    }
    if (!specular_group_safe(rough))
        throw std::invalid_argument("a specular group takes at most 4 levels of roughness above about 0.06 "
                                    "(3 above 0.03)");
    const int K = int(targets.size());
    const size_t texels = size_t(6) * n * n;
    std::vector<char> given(K);
    bool with_den = false;
    for (int k = 0; k < K; ++k) {
        SpecularGroupTarget& g = targets[k];
        given[k] = g.normaliser && g.normaliser->size() == texels;
        if (!given[k]) {
            with_den = true;
            if (g.normaliser) g.normaliser->assign(texels, 0.0f);
        }
    }
    // One traversal for all: the narrowest lobe's bins.
    const double r_min = *std::min_element(rough.begin(), rough.end());
    const LobeScales ls = lobe_scales(r_min);
    float a2[4] = {0, 0, 0, 0};
    float a2_min = 1.0f;
    for (int k = 0; k < K; ++k) {
        const float alpha = float(rough[k] * rough[k]);
        a2[k] = alpha * alpha;
        a2_min = std::min(a2_min, a2[k]);
    }
    const float inv_s = 1.0f / (2.0f * a2_min);
    for (int k = 0; k < K; ++k) a2[k] *= inv_s;  // the kernels take a2 / s
    const int T = std::max(1, std::min(q.tile, n));
    const int tiles_per_row = (n + T - 1) / T, tiles = 6 * tiles_per_row * tiles_per_row;
    std::vector<double> used(tiles, 0.0);
    parallel_for(0, tiles, [&](int tile) {
        const Tile t = make_tile(tile, n, T);
        thread_local std::vector<float> acc[10];
        used[tile] = double(gather_bins(tree, t, ls, float(q.eps), with_den, acc));
        const size_t padded = acc[0].size();
        const BinSoA bins = soa(acc);
        size_t k = 0;
        for (int j = t.j0; j < t.j1; ++j)
            for (int i = t.i0; i < t.i1; ++i, ++k) {
                double num[4][3], den[4];
                switch (K) {
                    case 1: group_sums<1>(with_den, bins, padded, a2, inv_s, t.dirs[k], num, den); break;
                    case 2: group_sums<2>(with_den, bins, padded, a2, inv_s, t.dirs[k], num, den); break;
                    case 3: group_sums<3>(with_den, bins, padded, a2, inv_s, t.dirs[k], num, den); break;
                    default: group_sums<4>(with_den, bins, padded, a2, inv_s, t.dirs[k], num, den); break;
                }
                const size_t idx = (size_t(t.face) * n + j) * n + i;
                for (int g = 0; g < K; ++g) {
                    SpecularGroupTarget& tg = targets[g];
                    // As specular_hierarchical: a computed denominator is
                    // rounded to float as the cache keeps it.
                    double d;
                    if (given[g]) {
                        d = (*tg.normaliser)[idx];
                    } else {
                        d = double(float(den[g]));
                        if (tg.normaliser) (*tg.normaliser)[idx] = float(d);
                    }
                    float* o = tg.dst->at(t.face, i, j);
                    for (int ch = 0; ch < 3; ++ch) o[ch] = d > 0.0 ? float(num[g][ch] / d) : 0.0f;
                }
            }
    });
    double total = 0.0;
    for (double u : used) total += u;
    return total / tiles;
}

}  // namespace iblbake
