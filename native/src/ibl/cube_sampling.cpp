#include "iblbake/ibl/cube_sampling.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "iblbake/ibl/source.h"
#include "iblbake/util/parallel.h"

namespace iblbake {

BorderedCube::BorderedCube(int n) : n_(n), data_(size_t(6) * (n + 2) * (n + 2) * 3, 0.0f) {}

BorderedCube BorderedCube::from_cube(const Cubemap& cube) {
    BorderedCube b(cube.size);
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < cube.size; ++j)
            std::copy_n(cube.at(f, 0, j), size_t(cube.size) * 3, b.at(f, 0, j));
    b.fill_borders();
    return b;
}

void BorderedCube::fill_borders() {
    const int n = n_;
    for (int f = 0; f < 6; ++f) {
        for (int j = -1; j <= n; ++j) {
            for (int i = -1; i <= n; ++i) {
                if (i >= 0 && i < n && j >= 0 && j < n) continue;
                // The border texel's centre, extended past the face, seen from
                // the neighbouring face: take that face's nearest texel.
                const double a = 2.0 * (i + 0.5) / n - 1.0, b = 2.0 * (j + 0.5) / n - 1.0;
                const FaceCoord fc = direction_to_face(face_point(f, a, b));
                const int si = std::clamp(int(fc.s * n), 0, n - 1);
                const int sj = std::clamp(int(fc.t * n), 0, n - 1);
                std::copy_n(at(fc.face, si, sj), 3, at(f, i, j));
            }
        }
    }
}

void BorderedCube::bilinear(const FaceCoordF& fc, float out[3]) const {
    const float x = fc.s * n_ - 0.5f, y = fc.t * n_ - 0.5f;  // in [-0.5, n - 0.5]
    const float xf = std::floor(x), yf = std::floor(y);
    const float tx = x - xf, ty = y - yf;
    const int x0 = std::clamp(int(xf), -1, n_ - 1), y0 = std::clamp(int(yf), -1, n_ - 1);
    const float* a = at(fc.face, x0, y0);
    const float* b = a + 3;
    const float* c = at(fc.face, x0, y0 + 1);
    const float* d = c + 3;
    for (int k = 0; k < 3; ++k) {
        const float top = a[k] + (b[k] - a[k]) * tx;
        const float bottom = c[k] + (d[k] - c[k]) * tx;
        out[k] = top + (bottom - top) * ty;
    }
}

void CubePyramid::trilinear(const Vec3& engine_dir, float lod, float out[3]) const {
    const FaceCoordF fc = direction_to_face(engine_dir);
    const float top = float(levels.size() - 1);
    lod = std::clamp(lod, 0.0f, top);
    const int l0 = int(lod);
    const float t = lod - l0;
    levels[l0].bilinear(fc, out);
    if (t > 0.0f && l0 + 1 < int(levels.size())) {
        float hi[3];
        levels[l0 + 1].bilinear(fc, hi);
        for (int k = 0; k < 3; ++k) out[k] += (hi[k] - out[k]) * t;
    }
}

namespace {
// Relative solid angle of texel (i, j) of an n-face: 1 / (1 + a^2 + b^2)^1.5.
inline double texel_weight(int i, int j, int n) {
    const double a = 2.0 * (i + 0.5) / n - 1.0, b = 2.0 * (j + 0.5) / n - 1.0;
    const double r2 = 1.0 + a * a + b * b;
    return 1.0 / (r2 * std::sqrt(r2));
}
}  // namespace

CubePyramid build_pyramid(const Cubemap& base) {
    CubePyramid p;
    p.levels.push_back(BorderedCube::from_cube(base));
    while (p.levels.back().size() > 1) {
        const BorderedCube& child = p.levels.back();
        const int cn = child.size(), n = cn / 2;
        BorderedCube parent(n);
        parallel_for(0, 6 * n, [&](int row) {
            const int f = row / n, j = row % n;
            for (int i = 0; i < n; ++i) {
                double acc[3] = {0, 0, 0}, wsum = 0.0;
                for (int dj = 0; dj < 2; ++dj)
                    for (int di = 0; di < 2; ++di) {
                        const int ci = 2 * i + di, cj = 2 * j + dj;
                        const double w = texel_weight(ci, cj, cn);
                        const float* c = child.at(f, ci, cj);
                        for (int k = 0; k < 3; ++k) acc[k] += w * c[k];
                        wsum += w;
                    }
                float* d = parent.at(f, i, j);
                for (int k = 0; k < 3; ++k) d[k] = float(acc[k] / wsum);
            }
        });
        parent.fill_borders();
        p.levels.push_back(std::move(parent));
    }
    return p;
}

void latlong_to_cube(Cubemap& dst, ImageView latlong, int supersample) {
    const int n = dst.size, ss = std::max(1, supersample);
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) {
            double acc[3] = {0, 0, 0}, wsum = 0.0;
            for (int sj = 0; sj < ss; ++sj)
                for (int si = 0; si < ss; ++si) {
                    const double a = 2.0 * (i + (si + 0.5) / ss) / n - 1.0;
                    const double b = 2.0 * (j + (sj + 0.5) / ss) / n - 1.0;
                    const double r2 = 1.0 + a * a + b * b;
                    const double w = 1.0 / (r2 * std::sqrt(r2));  // solid angle of the sub-texel
                    float v[3];
                    latlong_bilinear(latlong, face_point(f, a, b) / std::sqrt(r2), v);
                    for (int k = 0; k < 3; ++k) acc[k] += w * v[k];
                    wsum += w;
                }
            float* d = dst.at(f, i, j);
            for (int k = 0; k < 3; ++k) d[k] = float(acc[k] / wsum);
        }
    });
}

}  // namespace iblbake
