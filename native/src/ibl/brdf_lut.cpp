#include "iblbake/ibl/brdf_lut.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "iblbake/math/ggx.h"
#include "iblbake/math/quadrature.h"
#include "iblbake/math/spline.h"
#include "iblbake/util/parallel.h"

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

namespace {

// cos and sin of t in [0, pi/2] by Taylor series about pi/4 (|x| <= pi/4:
// error below 1e-14), in plain arithmetic so that loops over many t vectorise.
inline void sincos_quadrant(double t, double& c, double& sn) {
    const double x = t - 0.25 * kPi, x2 = x * x;
    double sx = 1.0 / 1307674368000.0;  // x^15 / 15!, Horner from the top
    sx = sx * -x2 + 1.0 / 6227020800.0;
    sx = sx * -x2 + 1.0 / 39916800.0;
    sx = sx * -x2 + 1.0 / 362880.0;
    sx = sx * -x2 + 1.0 / 5040.0;
    sx = sx * -x2 + 1.0 / 120.0;
    sx = sx * -x2 + 1.0 / 6.0;
    sx = (sx * -x2 + 1.0) * x;
    double cx = 1.0 / 20922789888000.0;  // x^16 / 16!
    cx = cx * -x2 + 1.0 / 87178291200.0;
    cx = cx * -x2 + 1.0 / 479001600.0;
    cx = cx * -x2 + 1.0 / 3628800.0;
    cx = cx * -x2 + 1.0 / 40320.0;
    cx = cx * -x2 + 1.0 / 720.0;
    cx = cx * -x2 + 1.0 / 24.0;
    cx = cx * -x2 + 0.5;
    cx = cx * -x2 + 1.0;
    const double r = 0.70710678118654752440;
    c = r * (cx - sx);
    sn = r * (cx + sx);
}

// Quadrature nodes of one (NdotV, roughness), gathered before the integrand
// runs over them in one loop the compiler vectorises. Head nodes come with
// cos^2 and sin^2 of theta_h (a, b); tail nodes with theta_h itself (a).
struct Nodes {
    std::vector<double> a, b, cphi, w;
    void clear() {
        a.clear();
        b.clear();
        cphi.clear();
        w.clear();
    }
    void add(double x, double y, double cp, double weight) {
        a.push_back(x);
        b.push_back(y);
        cphi.push_back(cp);
        w.push_back(weight);
    }
};

struct Integrand {
    double cos_v, sin_v, alpha, a2, k, g1v, lambda_v;
    // (w (1 - Fc) f, w Fc f), f = G (v.h) / (n.v n.h): the BRDF times n.l
    // over the sampling density of h.
    template <bool HC>
    void term(double cos2, double sin2, double cphi, double w, double& ta, double& tb) const {
        const double cos_h = std::sqrt(cos2), sin_h = std::sqrt(sin2);
        const double vdoth = sin_v * sin_h * cphi + cos_v * cos_h;
        const double ndotl = 2.0 * vdoth * cos_h - cos_v;
        const bool ok = ndotl > 0.0 && vdoth > 0.0;
        const double nl = ok ? ndotl : 1.0;
        double g;
        if constexpr (HC) {
            const double lambda_l = 0.5 * (std::sqrt(1.0 + a2 * std::fmax(0.0, 1.0 - nl * nl) / (nl * nl)) - 1.0);
            g = 1.0 / (1.0 + lambda_v + lambda_l);
        } else {
            g = g1v * nl / (nl * (1.0 - k) + k);
        }
        const double f = (ok ? w : 0.0) * g * vdoth / (cos_v * cos_h);
        const double m = 1.0 - vdoth, m2 = m * m, fc = m2 * m2 * m;
        ta = f * (1.0 - fc);
        tb = f * fc;
    }
};

// Sums over the nodes in kLanes fixed lanes (the loops vectorise; the order
// never depends on threads).
template <bool HC>
void sum_nodes(const Nodes& head_nodes, const Nodes& tail_nodes, const Integrand& in, double& a_sum,
               double& b_sum) {
    constexpr size_t kLanes = 8;
    double la[kLanes] = {}, lb[kLanes] = {};
    auto head = [&, &nd = head_nodes](size_t q, double& ta, double& tb) {
        in.template term<HC>(nd.a[q], nd.b[q], nd.cphi[q], nd.w[q], ta, tb);
    };
    auto tail = [&, &nd = tail_nodes](size_t q, double& ta, double& tb) {
        double c, sn;
        sincos_quadrant(nd.a[q], c, sn);
        const double cos2 = c * c, sin2 = sn * sn;
        in.template term<HC>(cos2, sin2, nd.cphi[q], nd.w[q] * ggx::D(in.alpha, cos2, sin2) * c * sn, ta, tb);
    };
    auto run = [&](size_t n, auto&& fn) {
        size_t p = 0;
        for (; p + kLanes <= n; p += kLanes)
            for (size_t l = 0; l < kLanes; ++l) {
                double ta, tb;
                fn(p + l, ta, tb);
                la[l] += ta;
                lb[l] += tb;
            }
        for (; p < n; ++p) {
            double ta, tb;
            fn(p, ta, tb);
            la[0] += ta;
            lb[0] += tb;
        }
    };
    run(head_nodes.w.size(), head);
    run(tail_nodes.w.size(), tail);
    for (size_t l = 0; l < kLanes; ++l) {
        a_sum += la[l];
        b_sum += lb[l];
    }
}

// The Gauss-Legendre rules on [0, 1], made once per LUT, not per texel.
struct LutRules {
    QuadratureRule phi, u;
    explicit LutRules(const LutQuality& q)
        : phi(gauss_legendre(q.phi_points, 0.0, 1.0)), u(gauss_legendre(q.u_points, 0.0, 1.0)) {}
};

LutValue integrate_with(double ndotv, double roughness, LutModel model, const LutRules& rules, Nodes& nodes,
                        Nodes& tail_nodes) {
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
    const Integrand in{cos_v, sin_v, alpha, alpha * alpha, k, ggx::g1_schlick(cos_v, k), ggx::smith_lambda(cos_v, alpha)};
    // Width in n.l over which G falls to 0 at the n.l = 0 limit: k for
    // Schlick-GGX, about alpha / (2 (1 + Lambda(v))) for height-correlated Smith.
    const double x_layer = hc ? alpha / (2.0 * (1.0 + in.lambda_v)) : k;
    const QuadratureRule& phi_unit = rules.phi;
    const QuadratureRule& u_unit = rules.u;
    const std::vector<double> half = azimuth_breaks(cos_v);
    double breaks[160];
    nodes.clear();
    tail_nodes.clear();

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
                int nb = 0;
                breaks[nb++] = 0.0;
                for (double b = theta0; b < theta_max && nb < 79; b *= 4.0) breaks[nb++] = b;
                for (double d = layer; d < 0.25 * (theta_max - theta0) && nb < 158; d *= 4.0)
                    breaks[nb++] = theta_max - d;
                breaks[nb++] = theta_max;
                std::sort(breaks, breaks + nb);
                for (int panel = 0; panel + 1 < nb; ++panel) {
                    const double lo = breaks[panel], hi = breaks[panel + 1];
                    if (!(hi > lo)) continue;
                    for (size_t iu = 0; iu < u_unit.nodes.size(); ++iu) {
                        if (panel == 0) {
                            const double t = t0 * u_unit.nodes[iu];
                            nodes.add(ggx::sample_cos2(alpha, t * t), ggx::sample_sin2(alpha, t * t), cphi,
                                      wphi * t0 * u_unit.weights[iu] * 2.0 * t);
                        } else {
                            tail_nodes.add(lo + (hi - lo) * u_unit.nodes[iu], 0.0, cphi,
                                           wphi * (hi - lo) * u_unit.weights[iu] * 2.0 * kPi);
                        }
                    }
                }
            }
        }
    }
    double a_sum = 0.0, b_sum = 0.0;
    if (hc) sum_nodes<true>(nodes, tail_nodes, in, a_sum, b_sum);
    else sum_nodes<false>(nodes, tail_nodes, in, a_sum, b_sum);
    // du dphi / (2 pi) over phi in [0, 2 pi): the two halves above cover [0, pi].
    LutValue r{a_sum / kPi, b_sum / kPi};
    if (model == LutModel::Multiscatter) r.a = 1.0 - r.b;
    return r;
}

}  // namespace

LutValue integrate_brdf(double ndotv, double roughness, LutModel model, const LutQuality& q) {
    if (!(ndotv >= 0.0 && ndotv <= 1.0) || !(roughness >= 0.0 && roughness <= 1.0))
        throw std::invalid_argument("integrate_brdf: NdotV and roughness must be in [0, 1]");
    Nodes nodes, tail;
    return integrate_with(ndotv, roughness, model, LutRules(q), nodes, tail);
}

namespace {

// One row of the LUT from q.row_nodes integrals and the spline through them.
void lut_row_from_nodes(Image& lut, int j, LutModel model, const LutRules& rules, int k,
                        const std::vector<double>& spline_matrix, Nodes& nodes, Nodes& tail) {
    const int size = lut.width;
    const double r = (j + 0.5) / size, shift = 0.02 * r * r;  // alpha / 50
    const double lo = std::log(0.5 / size + shift), hi = std::log(1.0 - 0.5 / size + shift);
    std::vector<double> ya(k), yb(k), ma(k, 0.0), mb(k, 0.0);
    for (int i = 0; i < k; ++i) {
        const double v = std::clamp(std::exp(lo + (hi - lo) * i / (k - 1)) - shift, 0.0, 1.0);
        const LutValue val = integrate_with(v, r, model, rules, nodes, tail);
        ya[i] = val.a;
        yb[i] = val.b;
    }
    for (int i = 0; i < k; ++i)
        for (int l = 0; l < k; ++l) {
            ma[i] += spline_matrix[size_t(i) * k + l] * ya[l];
            mb[i] += spline_matrix[size_t(i) * k + l] * yb[l];
        }
    for (int i = 0; i < size; ++i) {
        const double t = (std::log((i + 0.5) / size + shift) - lo) / (hi - lo) * (k - 1);
        float* p = lut.at(i, j);
        p[0] = float(spline_at(ya.data(), ma.data(), k, t));
        p[1] = float(spline_at(yb.data(), mb.data(), k, t));
        p[2] = 0.0f;
    }
}

}  // namespace

Image bake_brdf_lut(int size, LutModel model, const LutQuality& q) {
    if (size < 1) throw std::invalid_argument("LUT size must be >= 1");
    Image lut(size, size);
    const LutRules rules(q);
    const int k = q.row_nodes;
    if (k >= 4 && k < size) {
        const std::vector<double> spline_matrix = not_a_knot_matrix(k);
        parallel_for(0, size, [&](int j) {
            Nodes nodes, tail;
            lut_row_from_nodes(lut, j, model, rules, k, spline_matrix, nodes, tail);
        });
        return lut;
    }
    parallel_for(0, size, [&](int j) {
        const double r = (j + 0.5) / size;
        Nodes nodes, tail;  // one pair per row: the buffers are reused across its texels
        for (int i = 0; i < size; ++i) {
            const LutValue v = integrate_with((i + 0.5) / size, r, model, rules, nodes, tail);
            float* p = lut.at(i, j);
            p[0] = float(v.a);
            p[1] = float(v.b);
            p[2] = 0.0f;
        }
    });
    return lut;
}

}  // namespace iblbake
