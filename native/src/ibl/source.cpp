#include "iblbake/ibl/source.h"

#include <algorithm>
#include <cmath>

#include "iblbake/ibl/parallel.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/latlong.h"

namespace iblbake {

namespace {

// Per-image direction tables: cos/sin of longitude per column, of latitude
// per row, and each row's exact texel solid angle.
struct LatLongTables {
    std::vector<double> cos_phi, sin_phi, cos_lat, sin_lat, omega;
    LatLongTables(int w, int h) : cos_phi(w), sin_phi(w), cos_lat(h), sin_lat(h), omega(h) {
        for (int x = 0; x < w; ++x) {
            const double phi = (0.5 - (x + 0.5) / w) * 2.0 * kPi;
            cos_phi[x] = std::cos(phi);
            sin_phi[x] = std::sin(phi);
        }
        for (int y = 0; y < h; ++y) {
            const double lat = (0.5 - (y + 0.5) / h) * kPi;
            cos_lat[y] = std::cos(lat);
            sin_lat[y] = std::sin(lat);
            omega[y] = latlong_row_solid_angle(y, w, h);
        }
    }
    // Engine-space direction of texel (x, y).
    Vec3d engine_dir(int x, int y) const {
        return blender_to_engine(Vec3d{cos_lat[y] * cos_phi[x], cos_lat[y] * sin_phi[x], sin_lat[y]});
    }
};

inline float max3(const float* p) { return std::max(p[0], std::max(p[1], p[2])); }

}  // namespace

BadInputCounts sanitize(Image& img) {
    const int h = img.height;
    std::vector<BadInputCounts> rows(h);
    parallel_for(0, h, [&](int y) {
        BadInputCounts c;
        for (int x = 0; x < img.width; ++x) {
            float* p = img.at(x, y);
            bool bad = false;
            for (int k = 0; k < 3; ++k) {
                const float v = p[k];
                if (std::isnan(v)) { ++c.nan; bad = true; p[k] = 0.0f; }
                else if (std::isinf(v)) { ++c.inf; bad = true; p[k] = 0.0f; }
                else if (v < 0.0f) { ++c.negative; bad = true; p[k] = 0.0f; }
            }
            c.pixels += bad;
        }
        rows[y] = c;
    });
    BadInputCounts total;
    for (const auto& c : rows) {
        total.nan += c.nan; total.inf += c.inf; total.negative += c.negative; total.pixels += c.pixels;
    }
    return total;
}

void latlong_bilinear(const Image& img, const Vec3d& engine_dir, float out[3]) {
    const LatLongUV uv = direction_to_latlong(engine_to_blender(engine_dir));
    const int w = img.width, h = img.height;
    const double fx = uv.u * w - 0.5, fy = (1.0 - uv.v) * h - 0.5;
    const double x0f = std::floor(fx), y0f = std::floor(fy);
    const double tx = fx - x0f, ty = fy - y0f;
    int x0 = int(x0f) % w;
    if (x0 < 0) x0 += w;
    const int x1 = (x0 + 1) % w;
    const int y0 = std::clamp(int(y0f), 0, h - 1), y1 = std::clamp(int(y0f) + 1, 0, h - 1);
    const float* a = img.at(x0, y0);
    const float* b = img.at(x1, y0);
    const float* c = img.at(x0, y1);
    const float* d = img.at(x1, y1);
    for (int k = 0; k < 3; ++k) {
        const double top = a[k] + (b[k] - a[k]) * tx;
        const double bottom = c[k] + (d[k] - c[k]) * tx;
        out[k] = float(top + (bottom - top) * ty);
    }
}

HotSplit split_hot(const Image& img, double relative_threshold, int max_hot) {
    const int w = img.width, h = img.height;
    const LatLongTables tab(w, h);
    HotSplit out;
    out.rest = img;

    // Solid-angle-weighted mean of the largest channel, and the total power.
    std::vector<double> row_mean(h), row_power(h);
    parallel_for(0, h, [&](int y) {
        double s = 0.0, p = 0.0;
        for (int x = 0; x < w; ++x) {
            const float* px = img.at(x, y);
            s += max3(px);
            p += double(px[0]) + px[1] + px[2];
        }
        row_mean[y] = s * tab.omega[y];
        row_power[y] = p * tab.omega[y];
    });
    double mean = 0.0, total_power = 0.0;
    for (int y = 0; y < h; ++y) { mean += row_mean[y]; total_power += row_power[y]; }
    mean /= 4.0 * kPi;

    double threshold = relative_threshold * mean;
    std::vector<float> above;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float m = max3(img.at(x, y));
            if (m > threshold) above.push_back(m);
        }
    if (max_hot <= 0) {
        threshold = above.empty() ? threshold : double(*std::max_element(above.begin(), above.end()));
    } else if (int(above.size()) > max_hot) {
        // At most max_hot texels strictly above: the (max_hot+1)-th largest value.
        std::nth_element(above.begin(), above.begin() + max_hot, above.end(), std::greater<float>());
        threshold = above[max_hot];
    }
    out.threshold = threshold;

    double hot_power = 0.0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float* px = out.rest.at(x, y);
            const float m = max3(px);
            if (!(m > threshold)) continue;
            const float scale = float(threshold / m);
            RadiancePoint p;
            const Vec3d d = tab.engine_dir(x, y);
            p.dir[0] = float(d.x); p.dir[1] = float(d.y); p.dir[2] = float(d.z);
            for (int k = 0; k < 3; ++k) {
                const float rest = px[k] * scale;
                p.power[k] = float(double(px[k] - rest) * tab.omega[y]);
                hot_power += p.power[k];
                px[k] = rest;
            }
            out.hot.push_back(p);
        }
    out.hot_power_fraction = total_power > 0.0 ? hot_power / total_power : 0.0;
    return out;
}

void VectorCloud::add(const float dir[3], const float power[3]) {
    for (int c = 0; c < 3; ++c) {
        x[c].push_back(dir[0] * power[c]);
        y[c].push_back(dir[1] * power[c]);
        z[c].push_back(dir[2] * power[c]);
    }
}

VectorCloud reduce_to_vectors(const Image& img, int w, int h) {
    const int sw = img.width, sh = img.height;
    w = std::clamp(w, 1, sw);
    h = std::clamp(h, 1, sh);
    const LatLongTables tab(sw, sh);
    // Accumulate per bin row in parallel: bin rows own disjoint source rows.
    std::vector<double> acc(size_t(w) * h * 9, 0.0);
    parallel_for(0, h, [&](int by) {
        const int y0 = int((int64_t(by) * sh + h - 1) / h);  // first source row whose bin is by
        const int y1 = int((int64_t(by + 1) * sh + h - 1) / h);
        for (int y = y0; y < y1; ++y) {
            for (int x = 0; x < sw; ++x) {
                const int bx = int(int64_t(x) * w / sw);
                const float* px = img.at(x, y);
                const Vec3d d = tab.engine_dir(x, y) * tab.omega[y];
                double* a = &acc[(size_t(by) * w + bx) * 9];
                for (int c = 0; c < 3; ++c) {
                    a[c * 3 + 0] += d.x * px[c];
                    a[c * 3 + 1] += d.y * px[c];
                    a[c * 3 + 2] += d.z * px[c];
                }
            }
        }
    });
    VectorCloud cloud;
    for (size_t b = 0; b < size_t(w) * h; ++b) {
        const double* a = &acc[b * 9];
        bool empty = true;
        for (int k = 0; k < 9; ++k) empty = empty && a[k] == 0.0;
        if (empty) continue;
        for (int c = 0; c < 3; ++c) {
            cloud.x[c].push_back(float(a[c * 3 + 0]));
            cloud.y[c].push_back(float(a[c * 3 + 1]));
            cloud.z[c].push_back(float(a[c * 3 + 2]));
        }
    }
    return cloud;
}

std::array<Sh9, 3> project_sh9(const Image& img) {
    const int w = img.width, h = img.height;
    const LatLongTables tab(w, h);
    std::vector<std::array<Sh9, 3>> rows(h);
    parallel_for(0, h, [&](int y) {
        std::array<Sh9, 3> acc{};
        for (int x = 0; x < w; ++x) {
            const Sh9 basis = sh9_basis(tab.engine_dir(x, y));
            const float* px = img.at(x, y);
            for (int c = 0; c < 3; ++c)
                for (int i = 0; i < 9; ++i) acc[c][i] += basis[i] * px[c];
        }
        for (auto& ch : acc)
            for (double& v : ch) v *= tab.omega[y];
        rows[y] = acc;
    });
    std::array<Sh9, 3> total{};
    for (const auto& r : rows)  // fixed order: the same sum for any thread count
        for (int c = 0; c < 3; ++c)
            for (int i = 0; i < 9; ++i) total[c][i] += r[c][i];
    return total;
}

std::array<double, 3> mean_radiance(const Image& img) {
    const int w = img.width, h = img.height;
    std::array<double, 3> total{};
    for (int y = 0; y < h; ++y) {
        const double om = latlong_row_solid_angle(y, w, h);
        std::array<double, 3> row{};
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) row[c] += img.at(x, y)[c];
        for (int c = 0; c < 3; ++c) total[c] += row[c] * om;
    }
    for (double& v : total) v /= 4.0 * kPi;
    return total;
}

}  // namespace iblbake
