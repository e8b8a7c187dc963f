#include "reference.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "iblbake/ibl/source.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/ggx.h"
#include "iblbake/math/latlong.h"

namespace iblbake::ref {

namespace {

// Gauss-Legendre nodes and weights on [0, 1].
constexpr double kG2[2] = {0.5 - 0.28867513459481287, 0.5 + 0.28867513459481287};
constexpr double kG3[3] = {0.5 - 0.38729833462074170, 0.5, 0.5 + 0.38729833462074170};
constexpr double kW3[3] = {5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0};

// t = 1 - v (0 at the top of the file) of cell row yc = 0 .. h: [t0, t1].
void cell_row_extent(int yc, int h, double& t0, double& t1) {
    t0 = std::max(0.0, (yc - 0.5) / h);
    t1 = std::min(1.0, (yc + 0.5) / h);
}

// The four corner texels of cell (x, yc) and L there, bilinear at (a, b):
// a toward column x + 1, b toward row yc (from row yc - 1), rows clamped.
struct Cell {
    const float *l00, *l10, *l01, *l11;
    Cell(const Image& s, int x, int yc) {
        const int x1 = (x + 1) % s.width;
        const int y0 = std::clamp(yc - 1, 0, s.height - 1), y1 = std::clamp(yc, 0, s.height - 1);
        l00 = s.at(x, y0), l10 = s.at(x1, y0), l01 = s.at(x, y1), l11 = s.at(x1, y1);
    }
    void at(double a, double b, double out[3]) const {
        for (int c = 0; c < 3; ++c) {
            const double top = l00[c] + (l10[c] - l00[c]) * a, bottom = l01[c] + (l11[c] - l01[c]) * a;
            out[c] = top + (bottom - top) * b;
        }
    }
};

// K as a function of c = n.w and 1 - c (passed for precision), >= 0.
struct GgxKernel {
    double a2;
    double operator()(double c, double omc) const {
        const double t = omc + a2 * (1.0 + c);
        const double v = c / (t * t);  // up to the constant 4 a^2 / pi, which cancels in the ratio
        return c > 0.0 ? v : 0.0;
    }
};
struct CosineKernel {
    double operator()(double c, double) const { return c > 0.0 ? c : 0.0; }
};

// Cell (x, yc) split s x s, a q-point rule in each piece (q = 2 or 3), added
// into acc[0..2] (L K) and acc[3] (K), with sign `sign`.
template <typename Kernel>
void fine_cell(const TexelTable& t, const Vec3d& nb, const Kernel& k, int x, int yc, int s, int q, double sign,
               double acc[4]) {
    const Image& src = *t.src;
    const int w = t.w, h = t.h;
    double t0, t1;
    cell_row_extent(yc, h, t0, t1);
    const Cell cell(src, x, yc);
    const double* g = q == 2 ? kG2 : kG3;
    const double wg2[2] = {0.5, 0.5};
    const double* wg = q == 2 ? wg2 : kW3;
    const double du = 1.0 / (w * s), dt = (t1 - t0) / s;
    // Latitude nodes once per cell: cos, sin, weight, fraction b toward row yc.
    double cl[128 * 3], sl[128 * 3], wt[128 * 3], bf[128 * 3];
    const int nt = s * q;
    for (int sj = 0; sj < s; ++sj)
        for (int gj = 0; gj < q; ++gj) {
            const int k2 = sj * q + gj;
            const double tt = t0 + (sj + g[gj]) * dt, lat = kPi * (0.5 - tt);
            cl[k2] = std::cos(lat), sl[k2] = std::sin(lat);
            bf[k2] = std::clamp(tt * h - (yc - 0.5), 0.0, 1.0);
            wt[k2] = wg[gj] * dt * kPi * cl[k2] * 2.0 * kPi * du * sign;
        }
    for (int si = 0; si < s; ++si)
        for (int gi = 0; gi < q; ++gi) {
            const double fa = (si + g[gi]) / s;  // fraction across the cell in u
            const double phi = (0.5 - (x + 0.5 + fa) / w) * 2.0 * kPi;
            const double cp = std::cos(phi), sp = std::sin(phi);
            for (int k2 = 0; k2 < nt; ++k2) {
                const Vec3d d{cl[k2] * cp, cl[k2] * sp, sl[k2]};
                const double c = dot(nb, d);
                const Vec3d e = nb - d;
                const double kv = k(c, 0.5 * dot(e, e)) * wt[k2] * wg[gi];
                if (kv == 0.0) continue;
                double l[3];
                cell.at(fa, bf[k2], l);
                for (int ch = 0; ch < 3; ++ch) acc[ch] += l[ch] * kv;
                acc[3] += kv;
            }
        }
}

// integral L K and integral K over the sphere. `core` is the kernel's
// length scale at its peak (2 alpha), negative for a kernel without a peak
// (the cosine: then no cell is split but those on the horizon).
// Every cell first takes the 2 x 2 rule in one vectorised pass per row;
// cells on n's horizon or near n then have it replaced by a finer rule.
template <typename Kernel>
void integrate(const TexelTable& t, const Vec3d& n, const Kernel& k, double core, double acc[4]) {
    const int w = t.w, h = t.h;
    const Vec3d nb = engine_to_blender(n);
    const double rho = std::sqrt(nb.x * nb.x + nb.y * nb.y);
    std::vector<double> a[2], ac(w), cc(w);
    for (int g = 0; g < 2; ++g) {
        a[g].resize(w);
        for (int x = 0; x < w; ++x) a[g][x] = nb.x * t.cphi[g][x] + nb.y * t.sphi[g][x];
    }
    for (int x = 0; x < w; ++x) ac[x] = nb.x * t.ccphi[x] + nb.y * t.csphi[x];
    for (int k4 = 0; k4 < 4; ++k4) acc[k4] = 0.0;
    const size_t plane = size_t(w) + 1;
    for (int yc = 0; yc <= h; ++yc) {
        const double r = t.crad[yc], sr = t.sin_crad[yc];
        // The row's nearest cell centre to n is behind the horizon by more than a cell: nothing here.
        if (t.cclat[yc] * rho + nb.z * t.cslat[yc] < -sr) continue;
        double row[4] = {0, 0, 0, 0};
        for (int gj = 0; gj < 2; ++gj) {
            const double cl = t.clat[2 * yc + gj], sl = nb.z * t.slat[2 * yc + gj], wr = t.wrow[2 * yc + gj];
            const float* lv = t.lv.data() + size_t(2 * yc + gj) * 3 * plane;
            for (int g = 0; g < 2; ++g) {
                const double tu = kG2[g];
                const double* ag = a[g].data();
                // Eight fixed lanes of partial sums: the loop vectorises.
                constexpr int kL = 8;
                double s0[kL] = {}, s1[kL] = {}, s2[kL] = {}, sk[kL] = {};
                const int whole = w / kL * kL;
                auto term = [&](int x, int l) {
                    const double c = cl * ag[x] + sl;
                    const double kv = k(c, 1.0 - c);
                    s0[l] += kv * (lv[x] + (lv[x + 1] - lv[x]) * tu);
                    s1[l] += kv * (lv[plane + x] + (lv[plane + x + 1] - lv[plane + x]) * tu);
                    s2[l] += kv * (lv[2 * plane + x] + (lv[2 * plane + x + 1] - lv[2 * plane + x]) * tu);
                    sk[l] += kv;
                };
                for (int x0 = 0; x0 < whole; x0 += kL)
                    for (int l = 0; l < kL; ++l) term(x0 + l, l);
                for (int x = whole; x < w; ++x) term(x, 0);
                for (int l = 0; l < kL; ++l)
                    row[0] += s0[l] * wr, row[1] += s1[l] * wr, row[2] += s2[l] * wr, row[3] += sk[l] * wr;
            }
        }
        // Near: within 12 cell radii of n (the 2 x 2 rule needs the kernel's
        // length scale >= 12 cell radii), split to 0.15 of the length scale.
        // Cells of tiny sources (over 0.05 rad) are always split: no kernel
        // is smooth on a scale over about a radian.
        const bool big = r > 0.05;
        const double near_cos = core < 0.0 ? 2.0 : std::cos(std::min(kPi, 13.0 * r));
        for (int x = 0; x < w; ++x) cc[x] = t.cclat[yc] * ac[x] + nb.z * t.cslat[yc];
        for (int x = 0; x < w; ++x) {
            const double c = cc[x];
            const bool horizon = std::fabs(c) <= sr, near = c > near_cos;
            if (!horizon && !near && !big) continue;
            fine_cell(t, nb, k, x, yc, 1, 2, -1.0, row);  // the 2 x 2 rule's share, out
            if (horizon) {
                fine_cell(t, nb, k, x, yc, std::clamp(int(std::ceil(r / 0.005)), 3, 128), 3, 1.0, row);
            } else {
                const double d = std::max(0.0, std::acos(std::min(1.0, c)) - r);
                const double len = std::min(1.0, std::max({d, core, 0.05}));
                const int s = std::clamp(int(std::ceil(r / (0.15 * len))), 1, 128);
                fine_cell(t, nb, k, x, yc, s, 3, 1.0, row);
            }
        }
        for (int k4 = 0; k4 < 4; ++k4) acc[k4] += row[k4];
    }
}

}  // namespace

TexelTable texel_table(const Image& src) {
    TexelTable t;
    t.src = &src;
    const int w = src.width, h = src.height;
    t.w = w, t.h = h;
    for (int g = 0; g < 2; ++g) {
        t.cphi[g].resize(w), t.sphi[g].resize(w);
        for (int x = 0; x < w; ++x) {
            const double u = (x + 0.5 + kG2[g]) / w, phi = (0.5 - u) * 2.0 * kPi;
            t.cphi[g][x] = std::cos(phi), t.sphi[g][x] = std::sin(phi);
        }
    }
    t.ccphi.resize(w), t.csphi.resize(w);
    for (int x = 0; x < w; ++x) {
        const double phi = (0.5 - (x + 1.0) / w) * 2.0 * kPi;
        t.ccphi[x] = std::cos(phi), t.csphi[x] = std::sin(phi);
    }
    t.clat.resize(2 * (h + 1)), t.slat.resize(2 * (h + 1)), t.wrow.resize(2 * (h + 1));
    t.cclat.resize(h + 1), t.cslat.resize(h + 1), t.crad.resize(h + 1), t.sin_crad.resize(h + 1);
    const size_t plane = size_t(w) + 1;
    t.lv.resize(size_t(2 * (h + 1)) * 3 * plane);
    for (int yc = 0; yc <= h; ++yc) {
        double t0, t1;
        cell_row_extent(yc, h, t0, t1);
        const int y0 = std::clamp(yc - 1, 0, h - 1), y1 = std::clamp(yc, 0, h - 1);
        for (int g = 0; g < 2; ++g) {
            const int k = 2 * yc + g;
            const double tt = t0 + kG2[g] * (t1 - t0), lat = kPi * (0.5 - tt);
            t.clat[k] = std::cos(lat), t.slat[k] = std::sin(lat);
            const double tv = std::clamp(tt * h - (yc - 0.5), 0.0, 1.0);
            t.wrow[k] = 0.5 * (t1 - t0) * kPi * t.clat[k] * 2.0 * kPi / w * 0.5;
            float* lv = t.lv.data() + size_t(k) * 3 * plane;
            for (int x = 0; x <= w; ++x)
                for (int c = 0; c < 3; ++c) {
                    const double top = src.at(x % w, y0)[c], bottom = src.at(x % w, y1)[c];
                    lv[c * plane + x] = float(top + (bottom - top) * tv);
                }
        }
        const double tc = 0.5 * (t0 + t1), lat = kPi * (0.5 - tc);
        t.cclat[yc] = std::cos(lat), t.cslat[yc] = std::sin(lat);
        // Radius: the largest angle from the centre to the corners and edge midpoints.
        const Vec3d c{t.cclat[yc], 0.0, t.cslat[yc]};
        double min_cos = 1.0;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const double lt = kPi * (0.5 - (t0 + 0.5 * j * (t1 - t0)));
                const double ph = kPi * (i - 1.0) / w;
                min_cos = std::min(min_cos, dot(c, Vec3d{std::cos(lt) * std::cos(ph), std::cos(lt) * std::sin(ph), std::sin(lt)}));
            }
        t.crad[yc] = std::acos(std::clamp(min_cos, -1.0, 1.0)) * 1.0000001 + 1e-12;
        t.sin_crad[yc] = std::sin(std::min(t.crad[yc], 0.5 * kPi));
    }
    return t;
}

Rgb irradiance(const TexelTable& t, const Vec3d& n) {
    double acc[4];
    integrate(t, n, CosineKernel{}, -1.0, acc);
    return {acc[0] / kPi, acc[1] / kPi, acc[2] / kPi};
}

Rgb irradiance(const Image& src, const Vec3d& n) { return irradiance(texel_table(src), n); }

Rgb prefiltered(const TexelTable& t, const Vec3d& n, double roughness) {
    if (roughness == 0.0) {
        float v[3];
        latlong_bilinear(*t.src, n, v);
        return {v[0], v[1], v[2]};
    }
    const double alpha = roughness * roughness;
    double acc[4];
    integrate(t, n, GgxKernel{alpha * alpha}, 2.0 * alpha, acc);
    return {acc[0] / acc[3], acc[1] / acc[3], acc[2] / acc[3]};
}

Rgb prefiltered(const Image& src, const Vec3d& n, double roughness) {
    return prefiltered(texel_table(src), n, roughness);
}

double kernel_integral(const TexelTable& t, const Vec3d& n, double roughness) {
    const double alpha = roughness * roughness, a2 = alpha * alpha;
    double acc[4];
    integrate(t, n, GgxKernel{a2}, 2.0 * alpha, acc);
    return acc[3] * 4.0 * a2 / kPi;
}

std::array<double, 3> mean_radiance(const TexelTable& t) {
    std::array<double, 3> acc{0, 0, 0};
    const size_t plane = size_t(t.w) + 1;
    for (size_t k = 0; k < t.wrow.size(); ++k) {
        const float* lv = t.lv.data() + k * 3 * plane;
        for (int x = 0; x < t.w; ++x)
            for (int g = 0; g < 2; ++g)
                for (int c = 0; c < 3; ++c)
                    acc[c] += (lv[c * plane + x] + (lv[c * plane + x + 1] - lv[c * plane + x]) * kG2[g]) * t.wrow[k];
    }
    for (double& v : acc) v /= 4.0 * kPi;
    return acc;
}

Rgb irradiance_constant(const Image& src, const Vec3d& n) {
    Rgb acc{0, 0, 0};
    for (int y = 0; y < src.height; ++y) {
        const double om = latlong_row_solid_angle(y, src.width, src.height);
        for (int x = 0; x < src.width; ++x) {
            const double c = dot(n, blender_to_engine(latlong_texel_direction(x, y, src.width, src.height)));
            if (c <= 0) continue;
            for (int k = 0; k < 3; ++k) acc[k] += src.at(x, y)[k] * c * om;
        }
    }
    for (double& v : acc) v /= kPi;
    return acc;
}

Rgb prefiltered_constant(const Image& src, const Vec3d& n, double roughness) {
    const double alpha = roughness * roughness;
    Rgb acc{0, 0, 0};
    double wsum = 0.0;
    for (int y = 0; y < src.height; ++y) {
        const double om = latlong_row_solid_angle(y, src.width, src.height);
        for (int x = 0; x < src.width; ++x) {
            const Vec3d d = blender_to_engine(latlong_texel_direction(x, y, src.width, src.height));
            const Vec3d e = n - d;
            const double k = ggx::prefilter_kernel(alpha, 0.5 * dot(e, e)) * om;
            for (int c = 0; c < 3; ++c) acc[c] += src.at(x, y)[c] * k;
            wsum += k;
        }
    }
    for (double& v : acc) v /= wsum;
    return acc;
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

std::vector<BrightFeature> bright_features(const Image& src, size_t max_features) {
    const int w = src.width, h = src.height;
    double mean = 0.0, top = 0.0;
    for (int y = 0; y < h; ++y) {
        const double om = latlong_row_solid_angle(y, w, h);
        for (int x = 0; x < w; ++x) {
            const float* p = src.at(x, y);
            const double v = double(p[0]) + p[1] + p[2];
            mean += v * om;
            top = std::max(top, v);
        }
    }
    mean /= 4.0 * kPi;
    const double threshold = std::max(16.0 * mean, 0.05 * top);
    constexpr int gw = 256, gh = 128;
    std::vector<Vec3d> m(size_t(gw) * gh, Vec3d{0, 0, 0});
    std::vector<double> pw(size_t(gw) * gh, 0.0);
    for (int y = 0; y < h; ++y) {
        const double om = latlong_row_solid_angle(y, w, h);
        for (int x = 0; x < w; ++x) {
            const float* p = src.at(x, y);
            const double v = double(p[0]) + p[1] + p[2];
            if (!(v > threshold)) continue;
            const size_t g = size_t(std::min(gh - 1, y * gh / h)) * gw + std::min(gw - 1, x * gw / w);
            m[g] += blender_to_engine(latlong_texel_direction(x, y, w, h)) * (v * om);
            pw[g] += v * om;
        }
    }
    std::vector<BrightFeature> out;
    const double cell = 2.0 * kPi / gw;
    for (size_t g = 0; g < pw.size(); ++g)
        if (pw[g] > 0.0) out.push_back({normalize(m[g]), cell, pw[g]});
    std::sort(out.begin(), out.end(), [](const BrightFeature& a, const BrightFeature& b) { return a.power > b.power; });
    if (out.size() > max_features) out.resize(max_features);
    return out;
}

std::vector<MeasureTexel> measure_texels(int n, double roughness, const std::vector<BrightFeature>& bright,
                                         int per_level, int small_face, unsigned seed) {
    std::vector<MeasureTexel> out;
    if (n <= small_face) {
        for (const CubeTexel& t : sample_texels(n, 6 * n * n, seed)) out.push_back({t, true});
        return out;
    }
    std::vector<char> taken(size_t(6) * n * n, 0);
    for (const CubeTexel& t : sample_texels(n, per_level, seed)) {
        out.push_back({t, true});
        taken[(size_t(t.f) * n + t.j) * n + t.i] = 1;
    }
    const double alpha = roughness * roughness;
    const double texel = 0.5 * kPi / n;  // a texel's angle at a face centre
    const double radius = std::min(kPi / 6.0, std::max(6.0 * alpha, 3.0 * texel));
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const size_t k = (size_t(f) * n + j) * n + i;
                if (taken[k]) continue;
                const Vec3d d = texel_direction(f, i, j, n);
                for (const BrightFeature& b : bright)
                    if (dot(d, b.dir) >= std::cos(radius + b.radius)) {
                        out.push_back({{f, i, j}, false});
                        taken[k] = 1;
                        break;
                    }
            }
    return out;
}

LevelAccuracy level_accuracy(const std::vector<MeasureTexel>& texels, const std::vector<double>& out,
                             const std::vector<double>& ref, int n, double mean) {
    LevelAccuracy a;
    a.texels = texels.size();
    std::vector<double> e(texels.size()), rel;
    double se = 0, sr = 0, so = 0, sref = 0, sq = 0;
    for (size_t k = 0; k < texels.size(); ++k) {
        e[k] = texel_error(out[k], ref[k], mean);
        if (e[k] > a.max_e || k == 0) {
            a.max_e = e[k];
            a.worst = texels[k].t;
            a.worst_ref = ref[k];
            a.worst_out = out[k];
        }
        if (!texels[k].random) continue;
        ++a.random_texels;
        const double om = texel_solid_angle(texels[k].t.i, texels[k].t.j, n);
        se += om * (out[k] - ref[k]) * (out[k] - ref[k]);
        sr += om * ref[k] * ref[k];
        so += om * out[k];
        sref += om * ref[k];
        const double r = std::fabs(out[k] - ref[k]) / std::max(ref[k], 1e-30);
        rel.push_back(r);
        sq += r * r;
    }
    std::sort(e.begin(), e.end());
    a.p99_e = e.empty() ? 0.0 : e[std::min(e.size() - 1, size_t(0.99 * e.size()))];
    a.sa_rms = sr > 0 ? std::sqrt(se / sr) : 0.0;
    a.bias = sref > 0 ? so / sref - 1.0 : 0.0;
    if (!rel.empty()) {
        a.rel_rmse = std::sqrt(sq / rel.size());
        std::sort(rel.begin(), rel.end());
        a.rel_p99 = rel[std::min(rel.size() - 1, size_t(0.99 * rel.size()))];
    }
    return a;
}

ChannelAccuracy level_accuracy_rgb(const std::vector<MeasureTexel>& texels, const std::vector<Rgb>& out,
                                   const std::vector<Rgb>& ref, int n, const Rgb& mean) {
    ChannelAccuracy a;
    std::vector<double> o(out.size()), r(ref.size());
    for (int c = 0; c < 3; ++c) {
        for (size_t k = 0; k < out.size(); ++k) o[k] = out[k][c], r[k] = ref[k][c];
        const LevelAccuracy& l = a.channel[c] = level_accuracy(texels, o, r, n, mean[c]);
        if (c == 0 || l.max_e > a.max_e) a.max_e = l.max_e, a.worst_channel = c;
        a.p99_e = std::max(a.p99_e, l.p99_e);
        a.sa_rms = std::max(a.sa_rms, l.sa_rms);
        if (std::fabs(l.bias) > std::fabs(a.bias)) a.bias = l.bias;
    }
    return a;
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

namespace {

// A disc of radius_deg around blender_dir of radiance sun x sun_rgb on a sky
// of sky x sky_rgb x (0.5 + 0.5 max(0, z)).
Image disc_source(int w, int h, const Vec3d& blender_dir, double radius_deg, float sun, const float* sun_rgb, float sky,
                  const float* sky_rgb) {
    Image img(w, h);
    const double cr = std::cos(radius_deg * kPi / 180);
    const Vec3d d = normalize(blender_dir);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Vec3d t = latlong_texel_direction(x, y, w, h);
            float* p = img.at(x, y);
            const float base = sky * float(0.5 + 0.5 * std::max(0.0, t.z));
            const bool in_disc = dot(t, d) >= cr;
            for (int c = 0; c < 3; ++c) p[c] = in_disc ? sun * sun_rgb[c] : base * sky_rgb[c];
        }
    return img;
}

}  // namespace

Image sun_source(int w, int h, const Vec3d& blender_dir, double radius_deg, float sun, float sky) {
    const float sun_rgb[3] = {1.0f, 0.9f, 0.8f}, sky_rgb[3] = {1.0f, 1.0f, 1.2f};
    return disc_source(w, h, blender_dir, radius_deg, sun, sun_rgb, sky, sky_rgb);
}

Image red_sun_source(int w, int h, const Vec3d& blender_dir, double radius_deg, float sun, float sky) {
    const float sun_rgb[3] = {1.0f, 0.1f, 0.0f}, sky_rgb[3] = {0.1f, 0.3f, 1.0f};
    return disc_source(w, h, blender_dir, radius_deg, sun, sun_rgb, sky, sky_rgb);
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
