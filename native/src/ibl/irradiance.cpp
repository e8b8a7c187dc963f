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

void convolve_cube(Cubemap& dst, const VectorCloud& cloud) {
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) convolve_direction(cloud, texel_direction(f, i, j, n), dst.at(f, i, j));
    });
}

}  // namespace

void irradiance_convolve(Cubemap& dst, const VectorCloud& cloud, int exact_face_limit) {
    if (dst.size <= exact_face_limit) {
        convolve_cube(dst, cloud);
        return;
    }
    Cubemap coarse(exact_face_limit);
    convolve_cube(coarse, cloud);
    const BorderedCube src = BorderedCube::from_cube(coarse);
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) src.bilinear(Vec3(texel_direction(f, i, j, n)), dst.at(f, i, j));
    });
}

}  // namespace iblbake
