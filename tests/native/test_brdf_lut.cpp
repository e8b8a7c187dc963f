// The split-sum BRDF LUT: limits, reference points, an independent estimator.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "iblbake/ibl/brdf_lut.h"
#include "iblbake/math/spline.h"
#include "reference.h"

using namespace iblbake;

TEST(BrdfLut, MirrorLimit) {
    // r -> 0: A = 1 - (1 - NdotV)^5, B = (1 - NdotV)^5 (G -> 1, D -> delta).
    for (double nv : {0.05, 0.3, 0.7, 0.99}) {
        const LutValue v = integrate_brdf(nv, 1e-3, LutModel::Karis);
        const double fc = std::pow(1 - nv, 5);
        EXPECT_NEAR(v.a, 1 - fc, 2e-4) << nv;
        EXPECT_NEAR(v.b, fc, 2e-4) << nv;
    }
}

TEST(BrdfLut, NormalIncidenceRoughOne) {
    // NdotV = 1, r = 1: A + B = 1 - ln 2 for k = alpha / 2.
    const LutValue v = integrate_brdf(1.0, 1.0, LutModel::Karis);
    EXPECT_NEAR(v.a + v.b, 1 - std::log(2.0), 1e-6);
}

TEST(BrdfLut, KarisReferencePoints) {
    struct P { double nv, r, a, b; };
    const P points[] = {{0.5, 0.5, 0.7285345, 0.0185464},
                        {0.1, 0.25, 0.3912677, 0.2910908},
                        {0.75, 0.75, 0.5820536, 0.0014515}};
    double worst = 0;
    for (const P& p : points) {
        const LutValue v = integrate_brdf(p.nv, p.r, LutModel::Karis);
        worst = std::max({worst, std::fabs(v.a - p.a), std::fabs(v.b - p.b)});
        EXPECT_NEAR(v.a, p.a, 2e-4) << p.nv << " " << p.r;
        EXPECT_NEAR(v.b, p.b, 2e-4) << p.nv << " " << p.r;
    }
    std::printf("[LUT karis reference points] max abs error %.3e\n", worst);
}

TEST(BrdfLut, AgreesWithIndependentDenseEstimator) {
    // A dense midpoint rule in theta_h with no splitting, on a spread of points incl. grazing.
    double worst = 0;
    for (double nv : {0.01, 0.2, 0.6, 0.95})
        for (double r : {0.1, 0.4, 0.8, 1.0}) {
            const LutValue v = integrate_brdf(nv, r, LutModel::Karis);
            const auto e = ref::brdf_karis(nv, r, 4000, 2000);
            worst = std::max({worst, std::fabs(v.a - e[0]), std::fabs(v.b - e[1])});
            EXPECT_NEAR(v.a, e[0], 1e-4) << nv << " " << r;
            EXPECT_NEAR(v.b, e[1], 1e-4) << nv << " " << r;
        }
    std::printf("[LUT karis vs dense 4000x2000 midpoint estimator] max abs difference %.3e\n", worst);
}

TEST(BrdfLut, TexelLayoutAndFurnace) {
    const int n = 32;
    for (LutModel m : {LutModel::Karis, LutModel::HeightCorrelated, LutModel::Multiscatter}) {
        const Image lut = bake_brdf_lut(n, m);
        ASSERT_EQ(lut.width, n);
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const float* p = lut.at(i, j);
                ASSERT_TRUE(std::isfinite(p[0]) && std::isfinite(p[1]));
                EXPECT_GE(p[0], 0.0f);
                EXPECT_GE(p[1], 0.0f);
                EXPECT_LE(p[0] + p[1], 1.0f + 1e-5f) << lut_model_name(m);
                EXPECT_EQ(p[2], 0.0f);
            }
        // Texel (i, j) holds NdotV = (i + .5)/N, r = (j + .5)/N, j from the top.
        const LutValue v = integrate_brdf((3 + 0.5) / n, (20 + 0.5) / n, m);
        EXPECT_FLOAT_EQ(lut.at(3, 20)[0], float(v.a));
        EXPECT_FLOAT_EQ(lut.at(3, 20)[1], float(v.b));
    }
}

TEST(Spline, NotAKnotReproducesCubicsExactly) {
    // Not-a-knot ends make the spline exact on cubic polynomials, ends included.
    for (int n : {4, 5, 12, 64}) {
        auto f = [n](double t) { return 0.3 - 1.2 * t + 0.7 * t * t - 0.05 * t * t * t / n; };
        std::vector<double> y(n), m(n, 0.0);
        for (int i = 0; i < n; ++i) y[i] = f(i);
        const std::vector<double> s = not_a_knot_matrix(n);
        for (int i = 0; i < n; ++i)
            for (int l = 0; l < n; ++l) m[i] += s[size_t(i) * n + l] * y[l];
        for (double t = 0.0; t <= n - 1; t += 0.137)
            EXPECT_NEAR(spline_at(y.data(), m.data(), n, t), f(t), 1e-9 * (1 + std::fabs(f(t)))) << n << " " << t;
        EXPECT_DOUBLE_EQ(spline_at(y.data(), m.data(), n, n - 1.0), y[n - 1]);
    }
    EXPECT_THROW(not_a_knot_matrix(3), std::invalid_argument);
}

TEST(BrdfLut, RowNodesSplineMatchesEveryTexel) {
    // 64 integrals per row and a spline in log(NdotV + alpha/50) against the
    // LUT integrated at every texel: the interpolation adds at most 2e-5 at
    // 256, a fifth of the 1e-4 bound (2.7e-5 at 512 against high order, the quadrature's own
    // level), for every model, the grazing and smooth corners included.
    const int n = 256;
    for (LutModel m : {LutModel::Karis, LutModel::HeightCorrelated, LutModel::Multiscatter}) {
        LutQuality direct;
        direct.row_nodes = 0;
        const Image a = bake_brdf_lut(n, m, direct), b = bake_brdf_lut(n, m);
        double worst = 0.0;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i)
                for (int c = 0; c < 2; ++c) worst = std::max(worst, double(std::fabs(a.at(i, j)[c] - b.at(i, j)[c])));
        EXPECT_LT(worst, 2e-5) << lut_model_name(m);  // measured 1.4e-5
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) EXPECT_LE(b.at(i, j)[0] + b.at(i, j)[1], 1.0f + 1e-5f);
    }
    // k >= N: every texel is integrated, bit for bit.
    LutQuality many;
    many.row_nodes = 64;
    LutQuality none;
    none.row_nodes = 0;
    EXPECT_EQ(bake_brdf_lut(64, LutModel::Karis, many).pixels, bake_brdf_lut(64, LutModel::Karis, none).pixels);
}

TEST(BrdfLut, ModelsRelate) {
    // Height-correlated Smith masks less than separable Schlick-GGX here;
    // multiscatter is a white furnace at F0 = 1.
    const LutValue k = integrate_brdf(0.5, 0.7, LutModel::Karis);
    const LutValue h = integrate_brdf(0.5, 0.7, LutModel::HeightCorrelated);
    const LutValue m = integrate_brdf(0.5, 0.7, LutModel::Multiscatter);
    EXPECT_GT(h.a + h.b, 0.5);
    EXPECT_NE(k.a, h.a);
    EXPECT_NEAR(m.a + m.b, 1.0, 1e-12);
    EXPECT_EQ(m.b, h.b);
    EXPECT_THROW(lut_model_from_name("charlie"), std::invalid_argument);
}

TEST(BrdfLut, RoughnessZeroIsTheMirrorLimitAndBadInputsThrow) {
    const LutValue v = integrate_brdf(0.5, 0.0, LutModel::Karis);
    EXPECT_NEAR(v.a, 1 - std::pow(0.5, 5), 1e-12);
    EXPECT_NEAR(v.b, std::pow(0.5, 5), 1e-12);
    EXPECT_THROW(integrate_brdf(std::nan(""), 0.5, LutModel::Karis), std::invalid_argument);
    EXPECT_THROW(integrate_brdf(0.5, 1.5, LutModel::Karis), std::invalid_argument);
}
