#include "iblbake/ibl/irradiance.h"

#include <algorithm>
#include <cmath>

#include "iblbake/ibl/cube_sampling.h"
#include "iblbake/ibl/parallel.h"
#include "iblbake/math/cube.h"

namespace iblbake {

namespace {

// One output direction against the whole cloud: a structure-of-arrays sum
// in kLanes independent float partials (so the loop vectorises and the
// order is fixed), float within blocks, double across them.
void convolve_direction(const VectorCloud& cloud, const Vec3d& n, float out[3]) {
    constexpr size_t kLanes = 16, kBlock = 256;
    const float nx = float(n.x), ny = float(n.y), nz = float(n.z);
    const size_t count = cloud.size(), whole = count / kLanes * kLanes;
    for (int c = 0; c < 3; ++c) {
        const float* x = cloud.x[c].data();
        const float* y = cloud.y[c].data();
        const float* z = cloud.z[c].data();
        double total = 0.0;
        for (size_t b = 0; b < whole; b += kBlock) {
            const size_t e = std::min(whole, b + kBlock);
            float s[kLanes] = {};
            for (size_t p = b; p < e; p += kLanes)
                for (size_t l = 0; l < kLanes; ++l)
                    s[l] += std::max(0.0f, nx * x[p + l] + ny * y[p + l] + nz * z[p + l]);
            float t = 0.0f;
            for (float v : s) t += v;
            total += t;
        }
        for (size_t p = whole; p < count; ++p) total += std::max(0.0f, nx * x[p] + ny * y[p] + nz * z[p]);
        out[c] = float(total / kPi);
    }
}

// The hot points' share, (1/pi) sum P_c E[max(0, n.w)] over each point's hat.
void hot_direction(const std::vector<RadiancePoint>& hot, const Vec3d& n, float out[3]) {
    double acc[3] = {0, 0, 0};
    for (const RadiancePoint& p : hot) {
        const double mu = n.x * p.mean_dir[0] + n.y * p.mean_dir[1] + n.z * p.mean_dir[2];
        const float* c = p.cov;
        const double var = c[0] * n.x * n.x + c[1] * n.y * n.y + c[2] * n.z * n.z +
                           2.0 * (c[3] * n.x * n.y + c[4] * n.x * n.z + c[5] * n.y * n.z);
        double e = std::max(0.0, mu);
        if (var > 0.0 && mu * mu < 25.0 * var) {  // within 5 sigma of the horizon
            const double sigma = std::sqrt(var), z = mu / sigma;
            e = mu * 0.5 * std::erfc(-z / std::sqrt(2.0)) + sigma * std::exp(-0.5 * z * z) / std::sqrt(2.0 * kPi);
        }
        for (int ch = 0; ch < 3; ++ch) acc[ch] += p.power[ch] * e;
    }
    for (int ch = 0; ch < 3; ++ch) out[ch] += float(acc[ch] / kPi);
}

void convolve_cube(Cubemap& dst, const VectorCloud& cloud, const std::vector<RadiancePoint>& hot) {
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) {
            const Vec3d d = texel_direction(f, i, j, n);
            convolve_direction(cloud, d, dst.at(f, i, j));
            hot_direction(hot, d, dst.at(f, i, j));
        }
    });
}

}  // namespace

void irradiance_convolve(Cubemap& dst, const VectorCloud& cloud, const std::vector<RadiancePoint>& hot,
                         int exact_face_limit) {
    if (dst.size <= exact_face_limit) {
        convolve_cube(dst, cloud, hot);
        return;
    }
    Cubemap coarse(exact_face_limit);
    convolve_cube(coarse, cloud, hot);
    const BorderedCube src = BorderedCube::from_cube(coarse);
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) src.bilinear(Vec3(texel_direction(f, i, j, n)), dst.at(f, i, j));
    });
}

}  // namespace iblbake
