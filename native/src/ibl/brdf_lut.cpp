#include "iblbake/ibl/brdf_lut.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "iblbake/ibl/parallel.h"
#include "iblbake/math/ggx.h"
#include "iblbake/math/quadrature.h"

namespace iblbake {

const char* lut_model_name(LutModel m) {
    switch (m) {
        case LutModel::Karis: return "karis";
        case LutModel::HeightCorrelated: return "height-correlated";
        case LutModel::Multiscatter: return "multiscatter";
    }
    return "?";
}

LutModel lut_model_from_name(const std::string& name) {
    if (name == "karis") return LutModel::Karis;
    if (name == "height-correlated") return LutModel::HeightCorrelated;
    if (name == "multiscatter") return LutModel::Multiscatter;
    throw std::invalid_argument("unknown BRDF LUT model '" + name +
                                "' (expected karis, height-correlated or multiscatter)");
}

namespace {

// Azimuth panels on [0, pi/2], graded geometrically toward pi/2 down to a
// width of about NdotV / 4 (the width of the swing of the n.l = 0 limit).
std::vector<double> azimuth_breaks(double ndotv) {
    std::vector<double> breaks = {0.0};
    double d = 0.5 * kPi;
    const double finest = std::max(0.5 * ndotv, 1e-7);
    while (d > finest) {
        d *= 0.25;
        breaks.push_back(0.5 * kPi - d);
    }
    breaks.push_back(0.5 * kPi);
    return breaks;
}

}  // namespace

LutValue integrate_brdf(double ndotv, double roughness, LutModel model, const LutQuality& q) {
    if (!(ndotv >= 0.0 && ndotv <= 1.0) || !(roughness >= 0.0 && roughness <= 1.0))
        throw std::invalid_argument("integrate_brdf: NdotV and roughness must be in [0, 1]");
    const double alpha = roughness * roughness;
    if (alpha < 1e-9) {
        // The mirror limit: D is a delta at h = n, so l = reflect(v), G = 1.
        const double m = 1.0 - std::max(ndotv, 1e-7), fc = m * m * m * m * m;
        return {1.0 - fc, fc};  // multiscatter's A' = 1 - B is the same here
    }
    const double cos_v = std::clamp(ndotv, 1e-7, 1.0);
    const double sin_v = std::sqrt(std::max(0.0, 1.0 - cos_v * cos_v));
    const double k = alpha / 2.0;
    const bool hc = model != LutModel::Karis;
    const double g1v = ggx::g1_schlick(cos_v, k);
    const double lambda_v = ggx::smith_lambda(cos_v, alpha);
    // Width in n.l over which G falls to 0 at the n.l = 0 limit: k for
    // Schlick-GGX, about alpha / (2 (1 + Lambda(v))) for height-correlated Smith.
    const double x_layer = hc ? alpha / (2.0 * (1.0 + lambda_v)) : k;
    std::vector<double> breaks;

    const QuadratureRule phi_unit = gauss_legendre(q.phi_points, 0.0, 1.0);
    const QuadratureRule u_unit = gauss_legendre(q.u_points, 0.0, 1.0);
    const std::vector<double> half = azimuth_breaks(cos_v);

    double a_sum = 0.0, b_sum = 0.0;
    // phi in [0, pi] = [0, pi/2] and its mirror pi - phi; the integrand is even in phi.
    for (int side = 0; side < 2; ++side) {
        for (size_t p = 0; p + 1 < half.size(); ++p) {
            const double p0 = half[p], p1 = half[p + 1], pw = p1 - p0;
            for (size_t ip = 0; ip < phi_unit.nodes.size(); ++ip) {
                const double phi_h = p0 + pw * phi_unit.nodes[ip];
                const double phi = side == 0 ? phi_h : kPi - phi_h;
                const double wphi = pw * phi_unit.weights[ip];
                const double cphi = std::cos(phi);
                // n.l >= 0 for theta_h <= theta_max = psi/2 + pi/4.
                const double psi = std::atan2(sin_v * cphi, cos_v);
                const double theta_max = 0.5 * psi + 0.25 * kPi;
                if (theta_max <= 0.0) continue;
                // Head [0, theta_0] in t = sqrt(u), theta_0 = min(alpha, theta_max):
                // the peak, where u ~ theta^2. Then the tail in theta itself
                // (du = 2 pi D cos sin dtheta) on panels growing 4x: D's poles
                // sit at theta ~ +-i alpha, so each panel keeps them at the
                // same relative distance and Gauss-Legendre converges at a
                // fixed geometric rate for any alpha.
                const double theta0 = std::min(alpha, theta_max);
                const double c0 = std::cos(theta0), s0 = std::sin(theta0);
                const double t0 = std::sqrt(ggx::invert_sample(alpha, c0 * c0, s0 * s0));
                // Panel ends: 0, theta_0, 4 theta_0, 16 theta_0, ... up to theta_max,
                // merged with ends graded toward theta_max: there G switches off
                // across a layer about x_layer wide in n.l (n.l ~ 2 R
                // (theta_max - theta)), thin at grazing angles for
                // height-correlated Smith, where Lambda(v) is large.
                const double R = std::sqrt(cos_v * cos_v + sin_v * sin_v * cphi * cphi);
                const double layer = x_layer / (2.0 * std::max(R, 1e-12));
                breaks.assign({0.0});
                for (double b = theta0; b < theta_max; b *= 4.0) breaks.push_back(b);
                for (double d = layer; d < 0.25 * (theta_max - theta0); d *= 4.0) breaks.push_back(theta_max - d);
                breaks.push_back(theta_max);
                std::sort(breaks.begin(), breaks.end());
                for (size_t panel = 0; panel + 1 < breaks.size(); ++panel) {
                    const double panel_lo = breaks[panel], panel_hi = breaks[panel + 1];
                    if (!(panel_hi > panel_lo)) continue;
                    for (size_t iu = 0; iu < u_unit.nodes.size(); ++iu) {
                        double cos2, sin2, w;
                        if (panel == 0) {
                            const double t = t0 * u_unit.nodes[iu];
                            cos2 = ggx::sample_cos2(alpha, t * t);
                            sin2 = ggx::sample_sin2(alpha, t * t);
                            w = t0 * u_unit.weights[iu] * 2.0 * t;
                        } else {
                            const double th = panel_lo + (panel_hi - panel_lo) * u_unit.nodes[iu];
                            const double c = std::cos(th), sn = std::sin(th);
                            cos2 = c * c;
                            sin2 = sn * sn;
                            w = (panel_hi - panel_lo) * u_unit.weights[iu] * 2.0 * kPi * ggx::D(alpha, cos2, sin2) * c * sn;
                        }
                        const double cos_h = std::sqrt(cos2), sin_h = std::sqrt(sin2);
                        const double vdoth = sin_v * sin_h * cphi + cos_v * cos_h;
                        const double ndotl = 2.0 * vdoth * cos_h - cos_v;
                        if (ndotl <= 0.0 || vdoth <= 0.0) continue;
                        const double g = hc ? 1.0 / (1.0 + lambda_v + ggx::smith_lambda(ndotl, alpha))
                                            : g1v * ggx::g1_schlick(ndotl, k);
                        const double integrand = g * vdoth / (cos_v * cos_h);
                        const double m = 1.0 - vdoth, m2 = m * m;
                        const double fc = m2 * m2 * m;
                        w *= wphi;
                        a_sum += w * (1.0 - fc) * integrand;
                        b_sum += w * fc * integrand;
                    }
                }
            }
        }
    }
    // du dphi / (2 pi) over phi in [0, 2 pi): the two halves above cover [0, pi].
    LutValue r{a_sum / kPi, b_sum / kPi};
    if (model == LutModel::Multiscatter) r.a = 1.0 - r.b;
    return r;
}

Image bake_brdf_lut(int size, LutModel model, const LutQuality& q) {
    if (size < 1) throw std::invalid_argument("LUT size must be >= 1");
    Image lut(size, size);
    parallel_for(0, size, [&](int j) {
        const double r = (j + 0.5) / size;
        for (int i = 0; i < size; ++i) {
            const LutValue v = integrate_brdf((i + 0.5) / size, r, model, q);
            float* p = lut.at(i, j);
            p[0] = float(v.a);
            p[1] = float(v.b);
            p[2] = 0.0f;
        }
    });
    return lut;
}

}  // namespace iblbake
