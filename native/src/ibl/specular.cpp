#include "iblbake/ibl/specular.h"

#include <algorithm>
#include <cmath>

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

}  // namespace

double specular_hierarchical(Cubemap& dst, const BinTree& tree, double roughness, const HierarchicalQuality& q,
                             std::vector<float>* normaliser) {
    const size_t texels = size_t(6) * dst.size * dst.size;
    const bool given = normaliser && normaliser->size() == texels;
    if (normaliser && !given) normaliser->assign(texels, 0.0f);
    const float alpha = float(roughness * roughness), a2 = alpha * alpha;
    // The lobe's angular length scale in w: 2 alpha for narrow lobes, about
    // one radian (the cosine's) as alpha -> 1.
    const float scale = 2.0f * alpha / (1.0f + alpha);
    const float eps = float(q.eps);
    // K = D(h) max(0, n.w) has a kink at n's horizon with slope D(45 deg);
    // relative to the kernel's integral Z that slope sets how small bins that
    // straddle a horizon must be: length scale 0.1 / sqrt(D45 / Z).
    const double d45 = 4.0 * a2 / (kPi * (1.0 + a2) * (1.0 + a2));
    const float horizon_scale = float(std::min(kPi, 0.1 / std::sqrt(d45 / ggx::prefilter_normalizer(alpha))));
    const int n = dst.size, T = std::max(1, std::min(q.tile, n));
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

        // Traverse: accept a bin whole when it is small against the kernel's
        // length scale at its least distance from the tile.
        thread_local std::vector<float> acc[10];
        thread_local std::vector<int> stack;
        for (auto& a : acc) a.clear();
        stack.clear();
        const BinLevel& coarsest = tree.levels[top];
        for (int y = 0; y < coarsest.h; ++y)
            for (int x = 0; x < coarsest.w; ++x) stack.push_back((top << 26) | (y << 13) | x);
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
            const float length_scale = near_horizon ? std::min(horizon_scale, std::max(scale, dmin))
                                                    : std::max(scale, dmin);
            if (lvl == 0 || beta <= eps * length_scale) {
                acc[0].push_back(L.px[b]); acc[1].push_back(L.py[b]); acc[2].push_back(L.pz[b]);
                if (!given) {  // the solid-angle centroids serve the denominator alone
                    acc[3].push_back(L.cx[b]); acc[4].push_back(L.cy[b]); acc[5].push_back(L.cz[b]);
                    acc[9].push_back(L.omega[b]);
                }
                acc[6].push_back(L.power[0][b]); acc[7].push_back(L.power[1][b]); acc[8].push_back(L.power[2][b]);
            } else {
                const int cl = lvl - 1;
                for (int dy = 0; dy < 2; ++dy)
                    for (int dx = 0; dx < 2; ++dx)
                        stack.push_back((cl << 26) | ((2 * y + dy) << 13) | (2 * x + dx));
            }
        }
        const size_t count = acc[0].size();
        used[tile] = double(count);
        // Pad to whole lanes with bins of no power and no solid angle.
        const size_t padded = (count + kLanes - 1) / kLanes * kLanes;
        for (auto& a : acc)
            if (!a.empty() || !given) a.resize(padded, 0.0f);
        const BinSoA bins{acc[0].data(), acc[1].data(), acc[2].data(), acc[3].data(), acc[4].data(),
                          acc[5].data(), acc[6].data(), acc[7].data(), acc[8].data(), acc[9].data()};
        size_t k = 0;
        for (int j = j0; j < j1; ++j)
            for (int i = i0; i < i1; ++i, ++k) {
                double num[3], den;
                const size_t t = (size_t(face) * n + j) * n + i;
                // The denominator is geometry alone (bin centroids and solid
                // angles, the same bins for any source): a cached one is used
                // as is, a computed one is rounded to float as the cache keeps
                // it, so warm and cold bakes give the same bits.
                if (given) {
                    kernel_sums<false>(bins, padded, a2, dirs[k], num, den);
                    den = (*normaliser)[t];
                } else {
                    kernel_sums<true>(bins, padded, a2, dirs[k], num, den);
                    den = double(float(den));
                    if (normaliser) (*normaliser)[t] = float(den);
                }
                float* o = dst.at(face, i, j);
                for (int ch = 0; ch < 3; ++ch) o[ch] = den > 0.0 ? float(num[ch] / den) : 0.0f;
            }
    });
    double total = 0.0;
    for (double u : used) total += u;
    return total / tiles;
}

}  // namespace iblbake
