#include "iblbake/ibl/specular.h"

#include <algorithm>
#include <cmath>

#include "iblbake/ibl/parallel.h"
#include "iblbake/math/cube.h"
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

void specular_mirror(Cubemap& dst, const Image& latlong) {
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) latlong_bilinear(latlong, texel_direction(f, i, j, n), dst.at(f, i, j));
    });
}

namespace {

// Exact kernel sum of the hot points for one direction, divided by Z(alpha).
void hot_term(const std::vector<RadiancePoint>& hot, const Vec3& n, float alpha, float inv_z, float out[3]) {
    const float a2 = alpha * alpha;
    float acc[3] = {0, 0, 0};
    for (const RadiancePoint& p : hot) {
        const float dx = n.x - p.dir[0], dy = n.y - p.dir[1], dz = n.z - p.dir[2];
        const float omc = 0.5f * (dx * dx + dy * dy + dz * dz);  // 1 - n.w without cancellation
        const float c = 1.0f - omc;
        if (c <= 0.0f) continue;
        const float t = omc + a2 * (1.0f + c);
        const float k = 4.0f * a2 / (float(kPi) * t * t) * c;
        for (int ch = 0; ch < 3; ++ch) acc[ch] += k * p.power[ch];
    }
    for (int ch = 0; ch < 3; ++ch) out[ch] = acc[ch] * inv_z;
}

}  // namespace

void specular_prefilter(Cubemap& dst, const CubePyramid& rest, const std::vector<RadiancePoint>& hot,
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
}

int direct_bins_for(double roughness) {
    const double alpha = roughness * roughness;
    const double need = 6.0 * kPi / std::max(1e-6, 1.3 * alpha);
    int bins = 64;  // never coarser: the kernel's horizon kink needs them at any roughness
    while (bins < need && bins < (1 << 16)) bins <<= 1;
    return bins;
}

void specular_direct(Cubemap& dst, const PointCloud& rest, const std::vector<RadiancePoint>& hot, double roughness) {
    const float a2 = float(roughness * roughness * roughness * roughness);
    const int n = dst.size;
    const size_t count = rest.size();
    // K up to the constant 4 a^2 / pi, which cancels in the ratio.
    auto kernel = [a2](float nx, float ny, float nz, float x, float y, float z) {
        const float dx = nx - x, dy = ny - y, dz = nz - z;
        const float omc = 0.5f * (dx * dx + dy * dy + dz * dz);
        const float c = 1.0f - omc;
        const float t = omc + a2 * (1.0f + c);
        return c > 0.0f ? c / (t * t) : 0.0f;
    };
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) {
            const Vec3d d = texel_direction(f, i, j, n);
            const float nx = float(d.x), ny = float(d.y), nz = float(d.z);
            double num[3] = {0, 0, 0}, den = 0.0;
            constexpr size_t kBlock = 256;  // float partials, double across blocks
            for (size_t b = 0; b < count; b += kBlock) {
                const size_t e = std::min(count, b + kBlock);
                float s0 = 0, s1 = 0, s2 = 0, sw = 0;
                for (size_t p = b; p < e; ++p) {
                    const float k = kernel(nx, ny, nz, rest.x[p], rest.y[p], rest.z[p]);
                    s0 += k * rest.p[0][p];
                    s1 += k * rest.p[1][p];
                    s2 += k * rest.p[2][p];
                    sw += k * rest.omega[p];
                }
                num[0] += s0; num[1] += s1; num[2] += s2; den += sw;
            }
            for (const RadiancePoint& h : hot) {
                const float k = kernel(nx, ny, nz, h.dir[0], h.dir[1], h.dir[2]);
                for (int c = 0; c < 3; ++c) num[c] += double(k) * h.power[c];
            }
            float* o = dst.at(f, i, j);
            for (int c = 0; c < 3; ++c) o[c] = den > 0.0 ? float(num[c] / den) : 0.0f;
        }
    });
}

}  // namespace iblbake
