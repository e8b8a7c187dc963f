#include "iblbake/ibl/sun.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <utility>

#include "iblbake/ibl/source.h"
#include "iblbake/math/latlong.h"
#include "iblbake/util/parallel.h"

namespace iblbake {

double SunLight::elevation_deg() const { return std::asin(std::clamp(direction.z, -1.0, 1.0)) * 180.0 / kPi; }

namespace {

constexpr double kDeg = kPi / 180.0;
constexpr double kLum[3] = {0.2126, 0.7152, 0.0722};

inline double lum(const float* p) { return kLum[0] * p[0] + kLum[1] * p[1] + kLum[2] * p[2]; }

// Directions of texel centres (Blender world space) and their solid angles.
struct Grid {
    int w, h;
    std::vector<double> cos_phi, sin_phi, cos_lat, sin_lat, omega;
    Grid(int w_, int h_) : w(w_), h(h_), cos_phi(w_), sin_phi(w_), cos_lat(h_), sin_lat(h_), omega(h_) {
        for (int x = 0; x < w; ++x) {
            const Vec3d d = latlong_texel_direction(x, 0, w, 1);  // the column's longitude
            const double c = std::hypot(d.x, d.y);
            cos_phi[x] = d.x / c;
            sin_phi[x] = d.y / c;
        }
        for (int y = 0; y < h; ++y) {
            const double lat = (0.5 - (y + 0.5) / h) * kPi;
            cos_lat[y] = std::cos(lat);
            sin_lat[y] = std::sin(lat);
            omega[y] = latlong_row_solid_angle(y, w, h);
        }
    }
    Vec3d dir(int x, int y) const { return {cos_lat[y] * cos_phi[x], cos_lat[y] * sin_phi[x], sin_lat[y]}; }
    double texel_deg() const { return 180.0 / h; }
};

// The texels around a direction, within an angular radius (and a margin of
// two texels): rows y0..y1, columns x0 .. x0 + cols - 1 taken modulo the
// width (every column when the cap reaches a pole).
struct Window {
    int w = 0, h = 0, y0 = 0, y1 = 0, x0 = 0, cols = 0;
    bool full = false;  // every column: neighbours wrap around
    int rows() const { return y1 - y0 + 1; }
    size_t size() const { return size_t(rows()) * size_t(cols); }
    int gx(int i) const { return ((x0 + i) % w + w) % w; }
    int gy(int j) const { return y0 + j; }
    size_t at(int i, int j) const { return size_t(j) * size_t(cols) + size_t(i); }
    // The window index of (i + di, j + dj), around the seam when every
    // column is in; SIZE_MAX outside the window.
    size_t neighbour(int i, int j, int di, int dj) const {
        int ni = i + di;
        const int nj = j + dj;
        if (nj < 0 || nj >= rows()) return SIZE_MAX;
        if (full) ni = (ni + cols) % cols;
        else if (ni < 0 || ni >= cols) return SIZE_MAX;
        return at(ni, nj);
    }
    // The local column of global column x, or -1.
    int local_col(int x) const {
        const int i = ((x - x0) % w + w) % w;
        return i < cols ? i : -1;
    }
};

Window window_around(const Vec3d& d, double radius_deg, int w, int h) {
    Window win;
    win.w = w;
    win.h = h;
    const double r = radius_deg * kDeg, dphi = kPi / h, dlam = 2.0 * kPi / w;
    const double lat = std::asin(std::clamp(d.z, -1.0, 1.0));
    win.y0 = std::clamp(int(std::floor((0.5 * kPi - (lat + r)) / dphi)) - 2, 0, h - 1);
    win.y1 = std::clamp(int(std::floor((0.5 * kPi - (lat - r)) / dphi)) + 2, 0, h - 1);
    const bool polar = std::fabs(lat) + r >= 0.5 * kPi - 2.0 * dphi;
    double half = kPi;
    if (!polar) half = std::asin(std::min(1.0, std::sin(r) / std::cos(std::fabs(lat) + r)));
    const double xc = direction_to_latlong(d).u * w - 0.5;
    const int cols = int(std::ceil(2.0 * half / dlam)) + 6;
    if (polar || cols >= w) {
        win.full = true;
        win.x0 = 0;
        win.cols = w;
    } else {
        win.x0 = int(std::floor(xc - half / dlam)) - 3;
        win.cols = cols;
    }
    return win;
}

// The 8-connected region of `seed` where keep(i, j) holds, within the
// window; `touched_edge` says whether it reached the window's border.
std::vector<char> flood(const Window& win, int si, int sj, const std::function<bool(int, int)>& keep,
                        bool* touched_edge = nullptr) {
    std::vector<char> in(win.size(), 0);
    std::vector<std::pair<int, int>> stack{{si, sj}};
    in[win.at(si, sj)] = 1;
    bool edge = false;
    while (!stack.empty()) {
        const auto [i, j] = stack.back();
        stack.pop_back();
        if ((!win.full && (i == 0 || i == win.cols - 1)) || (j == 0 && win.y0 > 0) || (j == win.rows() - 1 && win.y1 < win.h - 1))
            edge = true;
        for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
                const size_t k = win.neighbour(i, j, di, dj);
                if (k == SIZE_MAX || in[k]) continue;
                const int ni = int(k % size_t(win.cols)), nj = int(k / size_t(win.cols));
                if (!keep(ni, nj)) continue;
                in[k] = 1;
                stack.emplace_back(ni, nj);
            }
    }
    if (touched_edge) *touched_edge = edge;
    return in;
}

// The diameter in degrees of the disc (spherical cap) of solid angle omega.
double cap_diameter_deg(double omega) { return 2.0 * std::acos(std::clamp(1.0 - omega / (2.0 * kPi), -1.0, 1.0)) / kDeg; }

std::string fmt(const char* f, double a, double b = 0.0, double c = 0.0) {
    char buf[256];
    std::snprintf(buf, sizeof buf, f, a, b, c);
    return buf;
}

// Per column x and per row y, the integrals of the bilinear reconstruction's
// hats (math/latlong.h): over longitude of H_x {1, cos phi, sin phi} and over
// s = sin(lat) of H_y {1, s, sqrt(1 - s^2)}. A texel's hat H_x H_y then has
//   solid angle  lon0[x] lat0[y]
//   moment       integral H w dw = (lonc[x] latc[y], lons[x] latc[y], lon0[x] lats[y])
// (Blender w = (cos lat cos phi, cos lat sin phi, sin lat), dw = dphi ds).
struct HatIntegrals {
    std::vector<double> lon0, lonc, lons, lat0, lats, latc;
    HatIntegrals(int w, int h) : lon0(w), lonc(w), lons(w), lat0(h), lats(h), latc(h) {
        for (const HatPiece& p : hat_pieces_lon(w, w)) {
            lon0[p.texel] += p.w[0];
            lonc[p.texel] += p.w[1];
            lons[p.texel] += p.w[2];
        }
        for (const HatPiece& p : hat_pieces_lat(h, h)) {
            lat0[p.texel] += p.w[0];
            lats[p.texel] += p.w[1];
            latc[p.texel] += p.w[3];
        }
    }
};

// The harmonic interpolation inside `mask` of the window's values around it,
// one channel (values: the window's texels, replaced inside the mask).
//
// Derivation: the Laplace-Beltrami equation on the unit sphere in latitude
// phi and longitude lambda, integrated over a texel's cell (finite volumes),
// is the sum of the fluxes through its four sides:
//   east/west  (dphi / (cos phi dlambda)) (f_E - f) and (f_W - f),
//   north      (cos phi_n dlambda / dphi) (f_N - f), phi_n its upper edge,
//   south      (cos phi_s dlambda / dphi) (f_S - f), phi_s its lower edge,
// and that sum is 0: f is the weighted mean of its four neighbours, with
// positive weights (so the discrete maximum principle holds: f lies between
// the smallest and the largest value around the region), zero through a
// pole (cos 90 degrees). The system is symmetric and diagonally dominant;
// successive over-relaxation solves it, with the relaxation factor of the
// model problem on the region's extent (2 / (1 + sin(pi / (n + 1)))).
void harmonic_fill(const Window& win, const std::vector<char>& mask, std::vector<double>& values) {
    const int w = win.w, h = win.h;
    const double dphi = kPi / h, dlam = 2.0 * kPi / w;
    struct Unknown {
        size_t k;
        size_t nb[4];   // neighbours' window indices (SIZE_MAX: none)
        double wt[4];
    };
    std::vector<Unknown> un;
    int extent = 1;
    {
        int imin = win.cols, imax = -1, jmin = win.rows(), jmax = -1;
        for (int j = 0; j < win.rows(); ++j)
            for (int i = 0; i < win.cols; ++i)
                if (mask[win.at(i, j)]) {
                    imin = std::min(imin, i), imax = std::max(imax, i), jmin = std::min(jmin, j), jmax = std::max(jmax, j);
                    const int y = win.gy(j);
                    const double lat = (0.5 - (y + 0.5) / h) * kPi;
                    Unknown u{};
                    u.k = win.at(i, j);
                    const double ew = dphi / (std::cos(lat) * dlam);
                    const double n = std::max(0.0, std::cos(lat + 0.5 * dphi)) * dlam / dphi;
                    const double s = std::max(0.0, std::cos(lat - 0.5 * dphi)) * dlam / dphi;
                    u.nb[0] = win.neighbour(i, j, 1, 0), u.wt[0] = ew;
                    u.nb[1] = win.neighbour(i, j, -1, 0), u.wt[1] = ew;
                    u.nb[2] = win.neighbour(i, j, 0, -1), u.wt[2] = n;
                    u.nb[3] = win.neighbour(i, j, 0, 1), u.wt[3] = s;
                    for (int q = 0; q < 4; ++q)
                        if (u.nb[q] == SIZE_MAX) u.wt[q] = 0.0;
                    un.push_back(u);
                }
        extent = std::max(imax - imin, jmax - jmin) + 1;
    }
    // The values around the region bound the solution.
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum = 0.0;
    size_t count = 0;
    for (const Unknown& u : un)
        for (int q = 0; q < 4; ++q)
            if (u.wt[q] > 0.0 && !mask[u.nb[q]]) {
                const double v = values[u.nb[q]];
                lo = std::min(lo, v), hi = std::max(hi, v), sum += v, ++count;
            }
    if (count == 0) {  // nothing around (a mask that covers the window): keep nothing
        for (const Unknown& u : un) values[u.k] = 0.0;
        return;
    }
    for (const Unknown& u : un) values[u.k] = sum / double(count);
    const double omega = 2.0 / (1.0 + std::sin(kPi / (extent + 1.0)));
    const double tol = 1e-9 * std::max(hi, 1e-30);
    for (int it = 0; it < 100000; ++it) {
        double change = 0.0;
        for (const Unknown& u : un) {
            double num = 0.0, den = 0.0;
            for (int q = 0; q < 4; ++q)
                if (u.wt[q] > 0.0) num += u.wt[q] * values[u.nb[q]], den += u.wt[q];
            const double target = num / den;
            const double next = values[u.k] + omega * (target - values[u.k]);
            change = std::max(change, std::fabs(next - values[u.k]));
            values[u.k] = next;
        }
        if (change <= tol) break;
    }
    for (const Unknown& u : un) values[u.k] = std::clamp(values[u.k], lo, hi);
}

}  // namespace

SunSplit split_sun(ImageView img, const SunCriteria& c) {
    SunSplit out;
    SunLight& sun = out.light;
    const int w = img.width, h = img.height;
    if (w < 1 || h < 1) {
        sun.why = "no light: the source is empty";
        return out;
    }
    const Grid g(w, h);

    // 1. The brightest texel.
    std::vector<double> row_max(h, -1.0);
    std::vector<int> row_arg(h, 0);
    parallel_for(0, h, [&](int y) {
        for (int x = 0; x < w; ++x) {
            const double v = lum(img.at(x, y));
            if (v > row_max[y]) row_max[y] = v, row_arg[y] = x;
        }
    });
    int py = int(std::max_element(row_max.begin(), row_max.end()) - row_max.begin());
    const int px = row_arg[py];
    const double peak = row_max[py];
    sun.peak_luminance = peak;
    if (!(peak > 0.0) || !std::isfinite(peak)) {
        sun.why = "no light: the source is black";
        return out;
    }
    const Vec3d pd = g.dir(px, py);
    auto angle_deg = [&](int x, int y) { return std::acos(std::clamp(dot(g.dir(x, y), pd), -1.0, 1.0)) / kDeg; };

    // 2. The core: texels of at least half the peak, connected to it. It is
    // followed out to a little beyond max_core from the peak (which may lie
    // on its edge): reaching farther means it is wider than max_core.
    const double max_core = std::max(c.max_core_diameter_deg, 3.0 * g.texel_deg());
    {
        const double reach = max_core + 3.0 * g.texel_deg();
        const Window win = window_around(pd, reach, w, h);
        const int si = win.local_col(px), sj = py - win.y0;
        bool edge = false;
        const std::vector<char> core = flood(
            win, si, sj,
            [&](int i, int j) {
                return lum(img.at(win.gx(i), win.gy(j))) >= 0.5 * peak && angle_deg(win.gx(i), win.gy(j)) <= reach;
            },
            &edge);
        double om = 0.0, extent = 0.0;
        for (int j = 0; j < win.rows(); ++j)
            for (int i = 0; i < win.cols; ++i)
                if (core[win.at(i, j)]) {
                    om += g.omega[win.gy(j)];
                    extent = std::max(extent, angle_deg(win.gx(i), win.gy(j)));
                }
        sun.core_diameter_deg = cap_diameter_deg(om);
        if (sun.core_diameter_deg > max_core || extent > max_core + g.texel_deg() || edge) {
            sun.why = fmt("no compact source: the brightest spot is %.3g degrees across or more (at most %.3g)",
                          std::max(sun.core_diameter_deg, extent), max_core);
            return out;
        }
    }

    // 3. Its surroundings: the median of the ring from 3 to 6 core radii.
    const double r_in = std::max(1.5 * sun.core_diameter_deg, 3.0 * g.texel_deg()), r_out = 2.0 * r_in;
    const Window win = window_around(pd, r_out + 2.0 * g.texel_deg(), w, h);
    {
        std::vector<double> ring;
        for (int j = 0; j < win.rows(); ++j)
            for (int i = 0; i < win.cols; ++i) {
                const double a = angle_deg(win.gx(i), win.gy(j));
                if (a >= r_in && a < r_out) ring.push_back(lum(img.at(win.gx(i), win.gy(j))));
            }
        if (!ring.empty()) {
            std::nth_element(ring.begin(), ring.begin() + ring.size() / 2, ring.end());
            sun.ring_luminance = ring[ring.size() / 2];
        }
        if (peak < c.min_contrast * sun.ring_luminance) {
            sun.why = fmt("no bright source: the brightest texel is %.3g times the sky %.2g to ", peak / sun.ring_luminance,
                          r_in) +
                      fmt("%.2g degrees around it (a sun is at least %.3g times)", r_out, c.min_contrast);
            return out;
        }
    }

    // 4. Alone: the brightest texel farther than the rival distance.
    {
        const double far = std::cos(std::max(c.rival_distance_deg, r_out) * kDeg);
        std::vector<double> best(h, 0.0);
        std::vector<int> at(h, -1);
        parallel_for(0, h, [&](int y) {
            for (int x = 0; x < w; ++x)
                if (dot(g.dir(x, y), pd) < far) {
                    const double v = lum(img.at(x, y));
                    if (v > best[y]) best[y] = v, at[y] = x;
                }
        });
        const int ry = int(std::max_element(best.begin(), best.end()) - best.begin());
        sun.rival_luminance = best[ry];
        if (at[ry] >= 0) sun.rival_distance_deg = angle_deg(at[ry], ry);
        if (sun.rival_luminance >= c.max_rival * peak) {
            sun.why = fmt("no dominant source: a texel %.3g degrees away is %.3g %% as bright as the brightest ",
                          sun.rival_distance_deg, 100.0 * sun.rival_luminance / peak) +
                      fmt("(a sun outshines every texel beyond %.3g degrees %.3g times)",
                          std::max(c.rival_distance_deg, r_out), 1.0 / c.max_rival);
            return out;
        }
    }

    // The sun's texels: above mask_factor x the ring's median, connected to
    // the peak, within the ring's outer radius; then their neighbours.
    const double level = c.mask_factor * sun.ring_luminance;
    const std::vector<char> body =
        flood(win, win.local_col(px), py - win.y0, [&](int i, int j) {
            return lum(img.at(win.gx(i), win.gy(j))) > level && angle_deg(win.gx(i), win.gy(j)) <= r_out;
        });
    std::vector<char> mask(win.size(), 0);
    for (int j = 0; j < win.rows(); ++j)
        for (int i = 0; i < win.cols; ++i) {
            if (!body[win.at(i, j)]) continue;
            for (int dj = -1; dj <= 1; ++dj)
                for (int di = -1; di <= 1; ++di) {
                    const size_t k = win.neighbour(i, j, di, dj);
                    if (k != SIZE_MAX) mask[k] = 1;
                }
        }

    // The sky behind it, channel by channel, and what is removed.
    std::vector<std::array<float, 3>> sunfree(win.size());
    {
        std::vector<double> values(win.size());
        for (int ch = 0; ch < 3; ++ch) {
            for (int j = 0; j < win.rows(); ++j)
                for (int i = 0; i < win.cols; ++i) values[win.at(i, j)] = img.at(win.gx(i), win.gy(j))[ch];
            harmonic_fill(win, mask, values);
            for (int j = 0; j < win.rows(); ++j)
                for (int i = 0; i < win.cols; ++i) {
                    const size_t k = win.at(i, j);
                    const float orig = img.at(win.gx(i), win.gy(j))[ch];
                    sunfree[k][ch] = mask[k] ? std::min(orig, float(values[k])) : orig;
                }
        }
    }

    // The light: the removed radiance's integrals over SPEC's bilinear L.
    const HatIntegrals hat(w, h);
    Vec3d vec[3];
    std::vector<double> dlum(win.size(), 0.0);
    for (int j = 0; j < win.rows(); ++j)
        for (int i = 0; i < win.cols; ++i) {
            const size_t k = win.at(i, j);
            if (!mask[k]) continue;
            const int x = win.gx(i), y = win.gy(j);
            const float* o = img.at(x, y);
            const Vec3d m{hat.lonc[x] * hat.latc[y], hat.lons[x] * hat.latc[y], hat.lon0[x] * hat.lats[y]};
            const double a = hat.lon0[x] * hat.lat0[y];
            double dl[3];
            for (int ch = 0; ch < 3; ++ch) {
                dl[ch] = double(o[ch]) - double(sunfree[k][ch]);
                vec[ch] += m * dl[ch];
                sun.removed_power[ch] += a * dl[ch];
            }
            dlum[k] = rec709_luminance(dl);
            ++sun.texels;
        }
    const Vec3d lv = vec[0] * kLum[0] + vec[1] * kLum[1] + vec[2] * kLum[2];
    if (!(length(lv) > 0.0)) {
        sun.why = "no compact source: nothing stands above the sky around the brightest texel";
        sun.texels = 0;
        return out;
    }
    sun.direction = normalize(lv);
    for (int ch = 0; ch < 3; ++ch) sun.illuminance[ch] = dot(sun.direction, vec[ch]);

    // Its diameter: the removed luminance's half-height region, measured on
    // the bilinear reconstruction at 8 x 8 points per texel.
    {
        auto dl_at = [&](int x, int y) -> double {  // removed luminance of texel (x, y), 0 outside the mask
            y = std::clamp(y, 0, h - 1);
            x = ((x % w) + w) % w;
            const int i = win.local_col(x), j = y - win.y0;
            if (i < 0 || j < 0 || j >= win.rows()) return 0.0;
            return dlum[win.at(i, j)];
        };
        constexpr int kSub = 8;
        std::vector<std::pair<double, double>> samples;  // (value, solid angle)
        double top = 0.0;
        for (int j = 0; j < win.rows(); ++j)
            for (int i = 0; i < win.cols; ++i) {
                const int x = win.gx(i), y = win.gy(j);
                bool near = false;
                for (int dj = -1; dj <= 1 && !near; ++dj)
                    for (int di = -1; di <= 1 && !near; ++di) near = dl_at(x + di, y + dj) > 0.0;
                if (!near) continue;
                for (int sj = 0; sj < kSub; ++sj)
                    for (int si = 0; si < kSub; ++si) {
                        const double fx = x + (si + 0.5) / kSub - 0.5, fy = y + (sj + 0.5) / kSub - 0.5;
                        const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
                        const double tx = fx - x0, ty = fy - y0;
                        const double v = (1 - ty) * ((1 - tx) * dl_at(x0, y0) + tx * dl_at(x0 + 1, y0)) +
                                         ty * ((1 - tx) * dl_at(x0, y0 + 1) + tx * dl_at(x0 + 1, y0 + 1));
                        const double lat = (0.5 - (y + (sj + 0.5) / kSub) / h) * kPi;
                        samples.emplace_back(v, std::cos(lat) * (2.0 * kPi / w) * (kPi / h) / (kSub * kSub));
                        top = std::max(top, v);
                    }
            }
        double om = 0.0;
        for (const auto& [v, a] : samples)
            if (v >= 0.5 * top) om += a;
        sun.angular_diameter_deg = cap_diameter_deg(om);
    }

    // Its share of the light on a surface facing it (texel-centre sums).
    {
        std::vector<double> sky_rows(h, 0.0);
        parallel_for(0, h, [&](int y) {
            double s = 0.0;
            const int j = y - win.y0;
            for (int x = 0; x < w; ++x) {
                const double cd = dot(g.dir(x, y), sun.direction);
                if (cd <= 0.0) continue;
                const int i = (j >= 0 && j < win.rows()) ? win.local_col(x) : -1;
                const float* p = i >= 0 ? sunfree[win.at(i, j)].data() : img.at(x, y);
                s += lum(p) * cd;
            }
            sky_rows[y] = s * g.omega[y];
        });
        double sky = 0.0;
        for (double v : sky_rows) sky += v;
        const double e = rec709_luminance(sun.illuminance);
        sun.irradiance_share = e / (e + sky);
    }

    sun.found = true;
    sun.why = fmt("sun at %.3g degrees elevation, %.3g degrees across, ", sun.elevation_deg(), sun.angular_diameter_deg) +
              fmt("%.3g %% of the light on a surface facing it", 100.0 * sun.irradiance_share);
    for (int j = 0; j < win.rows(); ++j) {
        bool any = false;
        for (int i = 0; i < win.cols; ++i) {
            const size_t k = win.at(i, j);
            if (!mask[k]) continue;
            out.texels.push_back({win.gx(i), win.gy(j), {sunfree[k][0], sunfree[k][1], sunfree[k][2]}});
            any = true;
        }
        if (any) out.rows.push_back(win.gy(j));
    }
    return out;
}

void apply_sun_split(Image& img, const SunSplit& split) {
    for (const SunTexel& t : split.texels) std::copy_n(t.rgb, 3, img.at(t.x, t.y));
}

ImageView sun_free_view(ImageView img, const SunSplit& split, std::vector<float>& store,
                        std::vector<const float*>& row_table) {
    if (split.texels.empty()) return img;
    const ImageView v = view_with_copied_rows(img, split.rows, store, row_table);
    const size_t n = size_t(img.width) * 3;
    for (const SunTexel& t : split.texels) {
        const size_t k = size_t(std::lower_bound(split.rows.begin(), split.rows.end(), t.y) - split.rows.begin());
        std::copy_n(t.rgb, 3, store.data() + k * n + size_t(t.x) * 3);
    }
    return v;
}

}  // namespace iblbake
