#include "baselines.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "iblbake/ibl/source.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/vec3.h"
#include "iblbake/util/parallel.h"

namespace iblbake::bench {

namespace {

constexpr float kPiF = 3.14159265359f;

// The shaders' ImportanceSampleGGX: h around N for the point Xi.
Vec3 importance_sample_ggx(float xi0, float xi1, const Vec3& n, float roughness) {
    const float a = roughness * roughness;
    const float phi = 2.0f * kPiF * xi0;
    const float cos_t = std::sqrt((1.0f - xi1) / (1.0f + (a * a - 1.0f) * xi1));
    const float sin_t = std::sqrt(1.0f - cos_t * cos_t);
    const Vec3 h{std::cos(phi) * sin_t, std::sin(phi) * sin_t, cos_t};
    const Vec3 up = std::fabs(n.z) < 0.999f ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
    const Vec3 tangent = normalize(cross(up, n));
    const Vec3 bitangent = cross(n, tangent);
    return normalize(tangent * h.x + bitangent * h.y + n * h.z);
}

float schlick_ggx(float ndotv, float roughness) {
    const float k = roughness * roughness / 2.0f;  // the LUT shader's k for IBL
    return ndotv / (ndotv * (1.0f - k) + k);
}

void lookup(const Image& src, const Vec3& d, float out[3]) { latlong_bilinear(src, Vec3d(d), out); }

int floor_log2(int n) {
    int l = 0;
    while ((n >> (l + 1)) > 0) ++l;
    return l;
}

}  // namespace

float radical_inverse_vdc(uint32_t bits) {
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    return float(bits) * 2.3283064365386963e-10f;
}

Image seed_brdf_lut(int size, int samples) {
    Image lut(size, size);
    const Vec3 n{0, 0, 1};
    parallel_for(0, size, [&](int j) {
        const float roughness = (j + 0.5f) / size;
        for (int i = 0; i < size; ++i) {
            const float ndotv = (i + 0.5f) / size;
            const Vec3 v{std::sqrt(1.0f - ndotv * ndotv), 0.0f, ndotv};
            float a = 0.0f, b = 0.0f;
            for (int s = 0; s < samples; ++s) {
                const Vec3 h = importance_sample_ggx(float(s) / float(samples), radical_inverse_vdc(uint32_t(s)), n,
                                                     roughness);
                const Vec3 l = normalize(h * (2.0f * dot(v, h)) - v);
                const float ndotl = std::fmax(l.z, 0.0f), ndoth = std::fmax(h.z, 0.0f);
                const float vdoth = std::fmax(dot(v, h), 0.0f);
                if (ndotl > 0.0f) {
                    const float g = schlick_ggx(ndotv, roughness) * schlick_ggx(ndotl, roughness);
                    const float g_vis = (g * vdoth) / (ndoth * ndotv);
                    const float fc = std::pow(1.0f - vdoth, 5.0f);
                    a += (1.0f - fc) * g_vis;
                    b += fc * g_vis;
                }
            }
            float* p = lut.at(i, j);
            p[0] = a / float(samples);
            p[1] = b / float(samples);
            p[2] = 0.0f;
        }
    });
    return lut;
}

void seed_irradiance_at(const Image& src, const Vec3& n, float delta, float out[3]) {
    Vec3 up{0, 1, 0};
    if (std::fabs(n.y) > 0.999f) up = {0, 0, 1};  // cross(up, N) would vanish
    const Vec3 right = normalize(cross(up, n));
    up = normalize(cross(n, right));
    float irr[3] = {0, 0, 0};
    float count = 0.0f;
    for (float phi = 0.0f; phi < 2.0f * kPiF; phi += delta)
        for (float theta = 0.0f; theta < 0.5f * kPiF; theta += delta) {
            const Vec3 t{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
            const Vec3 w = right * t.x + up * t.y + n * t.z;
            float l[3];
            lookup(src, w, l);
            const float cs = std::cos(theta) * std::sin(theta);
            for (int k = 0; k < 3; ++k) irr[k] += l[k] * cs;
            count += 1.0f;
        }
    for (int k = 0; k < 3; ++k) out[k] = kPiF * irr[k] * (1.0f / count);
}

Cubemap seed_irradiance(const Image& src, int face, float delta) {
    Cubemap out(face);
    parallel_for(0, 6 * face, [&](int row) {
        const int f = row / face, j = row % face;
        for (int i = 0; i < face; ++i) seed_irradiance_at(src, Vec3(texel_direction(f, i, j, face)), delta, out.at(f, i, j));
    });
    return out;
}

void seed_prefilter_at(const Image& src, const Vec3& n, float roughness, int samples, float out[3]) {
    float sum[3] = {0, 0, 0};
    float weight = 0.0f;
    for (int s = 0; s < samples; ++s) {
        const Vec3 h = importance_sample_ggx(float(s) / float(samples), radical_inverse_vdc(uint32_t(s)), n, roughness);
        const Vec3 l = normalize(h * (2.0f * dot(n, h)) - n);
        const float ndotl = std::fmax(dot(n, l), 0.0f);
        if (ndotl > 0.0f) {
            float c[3];
            lookup(src, l, c);
            for (int k = 0; k < 3; ++k) sum[k] += c[k] * ndotl;
            weight += ndotl;
        }
    }
    for (int k = 0; k < 3; ++k) out[k] = sum[k] / weight;
}

SeedSpecular seed_specular(const Image& src, int face, int samples) {
    SeedSpecular r;
    const int mips = floor_log2(face) + 1;
    for (int m = 0; m < mips; ++m) {
        const int n = std::max(1, face >> m);
        const float roughness = mips == 1 ? 0.0f : float(m) / float(mips - 1);
        Cubemap level(n);
        parallel_for(0, 6 * n, [&](int row) {
            const int f = row / n, j = row % n;
            for (int i = 0; i < n; ++i) {
                const Vec3 nrm(texel_direction(f, i, j, n));
                if (roughness == 0.0f) lookup(src, nrm, level.at(f, i, j));
                else seed_prefilter_at(src, nrm, roughness, samples, level.at(f, i, j));
            }
        });
        r.levels.push_back(std::move(level));
        r.roughness.push_back(roughness);
    }
    return r;
}

}  // namespace iblbake::bench
