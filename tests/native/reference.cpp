#include "reference.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "iblbake/ibl/source.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/ggx.h"
#include "iblbake/math/latlong.h"

namespace iblbake::ref {

TexelTable texel_table(const Image& src) {
    TexelTable t;
    t.src = &src;
    const size_t n = size_t(src.width) * src.height;
    t.x.resize(n), t.y.resize(n), t.z.resize(n), t.omega.resize(src.height);
    for (int y = 0; y < src.height; ++y) {
        t.omega[y] = latlong_row_solid_angle(y, src.width, src.height);
        for (int x = 0; x < src.width; ++x) {
            const Vec3d w = blender_to_engine(latlong_texel_direction(x, y, src.width, src.height));
            const size_t i = size_t(y) * src.width + x;
            t.x[i] = w.x, t.y[i] = w.y, t.z[i] = w.z;
        }
    }
    return t;
}

Rgb irradiance(const TexelTable& t, const Vec3d& n) {
    const Image& src = *t.src;
    Rgb acc{0, 0, 0};
    for (int y = 0; y < src.height; ++y) {
        const size_t row = size_t(y) * src.width;
        Rgb racc{0, 0, 0};
        for (int x = 0; x < src.width; ++x) {
            const size_t i = row + x;
            const double c = n.x * t.x[i] + n.y * t.y[i] + n.z * t.z[i];
            if (c <= 0) continue;
            for (int k = 0; k < 3; ++k) racc[k] += src.pixels[i * 3 + k] * c;
        }
        for (int k = 0; k < 3; ++k) acc[k] += racc[k] * t.omega[y];
    }
    for (double& v : acc) v /= kPi;
    return acc;
}

Rgb irradiance(const Image& src, const Vec3d& n) { return irradiance(texel_table(src), n); }

Rgb prefiltered(const TexelTable& t, const Vec3d& n, double roughness) {
    const Image& src = *t.src;
    if (roughness == 0.0) {
        float v[3];
        latlong_bilinear(src, n, v);
        return {v[0], v[1], v[2]};
    }
    const double alpha = roughness * roughness;
    Rgb acc{0, 0, 0};
    double wsum = 0.0;
    for (int y = 0; y < src.height; ++y) {
        const size_t row = size_t(y) * src.width;
        Rgb racc{0, 0, 0};
        double rw = 0.0;
        for (int x = 0; x < src.width; ++x) {
            const size_t i = row + x;
            const double dx = n.x - t.x[i], dy = n.y - t.y[i], dz = n.z - t.z[i];
            const double k = ggx::prefilter_kernel(alpha, 0.5 * (dx * dx + dy * dy + dz * dz));
            if (k == 0.0) continue;
            for (int c = 0; c < 3; ++c) racc[c] += src.pixels[i * 3 + c] * k;
            rw += k;
        }
        for (int c = 0; c < 3; ++c) acc[c] += racc[c] * t.omega[y];
        wsum += rw * t.omega[y];
    }
    for (double& v : acc) v /= wsum;
    return acc;
}

Rgb prefiltered(const Image& src, const Vec3d& n, double roughness) {
    return prefiltered(texel_table(src), n, roughness);
}

std::array<double, 2> brdf_karis(double ndotv, double roughness, int n_theta, int n_phi) {
    // Midpoint rule in (x, phi) over the whole hemisphere of h, theta_h =
    // alpha tan(x X) (X = atan(pi / 2 alpha)) to put points where the peak is,
    // with the measure D cos sin dtheta dphi; terms with n.l <= 0 are 0.
    const double alpha = roughness * roughness, k = alpha / 2;
    const double sv = std::sqrt(1 - ndotv * ndotv);
    const double X = std::atan(0.5 * kPi / alpha);
    double a = 0, b = 0;
    const double dx = 1.0 / n_theta, dph = 2 * kPi / n_phi;
    for (int j = 0; j < n_phi; ++j) {
        const double cp = std::cos((j + 0.5) * dph);
        for (int i = 0; i < n_theta; ++i) {
            const double x = (i + 0.5) * dx, tx = std::tan(x * X);
            const double th = alpha * tx, dth = alpha * X * (1 + tx * tx) * dx;
            const double ch = std::cos(th), sh = std::sin(th);
            const double vh = sv * sh * cp + ndotv * ch;
            const double nl = 2 * vh * ch - ndotv;
            if (nl <= 0 || vh <= 0) continue;
            const double g = ggx::g1_schlick(ndotv, k) * ggx::g1_schlick(nl, k);
            const double f = g * vh / (ndotv * ch) * ggx::D(alpha, ch * ch, sh * sh) * ch * sh * dth;
            const double fc = std::pow(1 - vh, 5);
            a += (1 - fc) * f;
            b += fc * f;
        }
    }
    return {a * dph, b * dph};
}

std::vector<CubeTexel> sample_texels(int n, int k, unsigned seed) {
    std::vector<CubeTexel> all;
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) all.push_back({f, i, j});
    if (int(all.size()) <= k) return all;
    std::mt19937 rng(seed);
    std::shuffle(all.begin(), all.end(), rng);
    all.resize(k);
    return all;
}

Image constant_source(int w, int h, float value) {
    Image img(w, h);
    std::fill(img.pixels.begin(), img.pixels.end(), value);
    return img;
}

Image random_smooth_source(int w, int h, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> U(0, 1);
    struct Wave { double fx, fy, ph, amp; int ch; };
    std::vector<Wave> waves;
    for (int i = 0; i < 12; ++i)
        waves.push_back({double(1 + int(U(rng) * 6)), 1 + U(rng) * 5, U(rng) * 6.28, 0.3 * U(rng), i % 3});
    Image img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const double u = (x + 0.5) / w, v = (y + 0.5) / h;
            float* p = img.at(x, y);
            for (int c = 0; c < 3; ++c) p[c] = 1.0f;
            for (const Wave& wv : waves)
                p[wv.ch] += float(wv.amp * std::sin(2 * kPi * wv.fx * u + kPi * wv.fy * v + wv.ph));
            // some sharp features: a bright rectangle and a dark band
            if (u > 0.3 && u < 0.36 && v > 0.2 && v < 0.3) p[0] += 8, p[1] += 6, p[2] += 4;
            if (v > 0.6 && v < 0.62) p[0] *= 0.1f, p[1] *= 0.1f, p[2] *= 0.1f;
        }
    return img;
}

Image sun_source(int w, int h, const Vec3d& blender_dir, double radius_deg, float sun, float sky) {
    Image img(w, h);
    const double cr = std::cos(radius_deg * kPi / 180);
    const Vec3d d = normalize(blender_dir);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Vec3d t = latlong_texel_direction(x, y, w, h);
            float* p = img.at(x, y);
            const float base = sky * float(0.5 + 0.5 * std::max(0.0, t.z));
            p[0] = base; p[1] = base; p[2] = base * 1.2f;
            if (dot(t, d) >= cr) p[0] = sun, p[1] = sun * 0.9f, p[2] = sun * 0.8f;
        }
    return img;
}

std::array<double, 3> mean_radiance(const Image& img) {
    std::array<double, 3> total{};
    for (int y = 0; y < img.height; ++y) {
        const double om = latlong_row_solid_angle(y, img.width, img.height);
        for (int x = 0; x < img.width; ++x)
            for (int c = 0; c < 3; ++c) total[c] += img.at(x, y)[c] * om;
    }
    for (double& v : total) v /= 4.0 * kPi;
    return total;
}

}  // namespace iblbake::ref
