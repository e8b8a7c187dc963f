// Cube and lat-long geometry of SPEC.md sections 1 and 2, quadrature, GGX sampling.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <random>
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/fast_math.h"
#include "iblbake/math/ggx.h"
#include "iblbake/math/latlong.h"
#include "iblbake/math/quadrature.h"

using namespace iblbake;

TEST(Cube, FaceTableMatchesOpenGL) {
    // The spec's table: (ma, sc, tc) per face.
    const Vec3d expect[6][3] = {
        {{1, 0, 0}, {0, 0, -1}, {0, -1, 0}}, {{-1, 0, 0}, {0, 0, 1}, {0, -1, 0}},
        {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}},   {{0, -1, 0}, {1, 0, 0}, {0, 0, -1}},
        {{0, 0, 1}, {1, 0, 0}, {0, -1, 0}},  {{0, 0, -1}, {-1, 0, 0}, {0, -1, 0}}};
    for (int f = 0; f < 6; ++f) {
        const FaceFrame& fr = kFaceFrames[f];
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(fr.ma[k], expect[f][0][k]);
            EXPECT_EQ(fr.s[k], expect[f][1][k]);
            EXPECT_EQ(fr.t[k], expect[f][2][k]);
        }
    }
}

TEST(Cube, TexelDirectionRoundTrips) {
    for (int n : {1, 2, 3, 16, 255}) {
        for (int f = 0; f < 6; ++f)
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i) {
                    const FaceCoord fc = direction_to_face(texel_direction(f, i, j, n));
                    ASSERT_EQ(fc.face, f);
                    EXPECT_NEAR(fc.s, (i + 0.5) / n, 1e-12);
                    EXPECT_NEAR(fc.t, (j + 0.5) / n, 1e-12);
                    const FaceCoordF ff = direction_to_face(Vec3(texel_direction(f, i, j, n)));
                    EXPECT_EQ(ff.face, f);
                }
    }
}

TEST(Cube, MajorAxesLandOnFaceCentres) {
    const Vec3d axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int f = 0; f < 6; ++f) {
        const FaceCoord fc = direction_to_face(axes[f]);
        EXPECT_EQ(fc.face, f);
        EXPECT_DOUBLE_EQ(fc.s, 0.5);
        EXPECT_DOUBLE_EQ(fc.t, 0.5);
    }
    // s runs left to right, t top to bottom: the +Z face's top edge is +Y (up).
    const FaceCoord up = direction_to_face(Vec3d{0, 0.5, 1});
    EXPECT_EQ(up.face, 4);
    EXPECT_LT(up.t, 0.5);
}

TEST(Cube, BlenderToEngineAxes) {
    // Blender +X -> engine +X, Blender +Z (up) -> engine +Y, Blender -Y -> engine +Z.
    EXPECT_EQ(direction_to_face(blender_to_engine(Vec3d{1, 0, 0})).face, int(Face::PosX));
    EXPECT_EQ(direction_to_face(blender_to_engine(Vec3d{0, 0, 1})).face, int(Face::PosY));
    EXPECT_EQ(direction_to_face(blender_to_engine(Vec3d{0, -1, 0})).face, int(Face::PosZ));
    const Vec3d b{0.3, -0.5, 0.8};
    const Vec3d back = engine_to_blender(blender_to_engine(b));
    EXPECT_EQ(back.x, b.x);
    EXPECT_EQ(back.y, b.y);
    EXPECT_EQ(back.z, b.z);
}

TEST(Cube, TexelSolidAnglesSumToSphereAtEverySize) {
    for (int n : {1, 2, 7, 64, 1024, 2048}) {
        double face = 0.0;
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) face += texel_solid_angle(i, j, n);
        EXPECT_NEAR(6.0 * face, 4.0 * kPi, 1e-9) << "n = " << n;
    }
    // The centre texel of a 2048 face: exact value (2/n)^2 / (1 + tiny)^1.5 to 1e-9 relative.
    const int n = 2048;
    const double a = 1.0 / n;
    const double centre = texel_solid_angle(n / 2, n / 2, n);
    EXPECT_NEAR(centre / (4.0 / (double(n) * n)), 1.0 / std::pow(1 + a * a / 2, 1.5), 1e-6);
}

TEST(Cube, CrossLayout) {
    Cubemap c(2);
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i) c.at(f, i, j)[0] = float(f + 1);
    const std::vector<float> rgba = cube_to_hcross_rgba(c);
    ASSERT_EQ(rgba.size(), size_t(8 * 6 * 4));
    Image x(8, 6);
    std::vector<float> alpha(8 * 6);
    for (size_t p = 0; p < alpha.size(); ++p) {
        for (int k = 0; k < 3; ++k) x.pixels[p * 3 + k] = rgba[p * 4 + k];
        alpha[p] = rgba[p * 4 + 3];
    }
    // Row 0: . +Y . . ; row 1: -X +Z +X -Z ; row 2: . -Y . .
    const int expect[3][4] = {{0, 3, 0, 0}, {2, 5, 1, 6}, {0, 4, 0, 0}};
    for (int r = 0; r < 3; ++r)
        for (int col = 0; col < 4; ++col) {
            EXPECT_EQ(x.at(col * 2 + 1, r * 2 + 1)[0], float(expect[r][col])) << r << "," << col;
            EXPECT_EQ(alpha[size_t(r * 2) * 8 + col * 2], expect[r][col] ? 1.0f : 0.0f);
        }
    const Cubemap back = hcross_to_cube(x);
    EXPECT_EQ(back.pixels, c.pixels);
}

TEST(LatLong, MappingOfSpec) {
    // u = 0.5 looks along +X, u = 0.25 along +Y, u = 0.75 along -Y, top row is +Z.
    auto uv = direction_to_latlong({1, 0, 0});
    EXPECT_NEAR(uv.u, 0.5, 1e-12);
    EXPECT_NEAR(uv.v, 0.5, 1e-12);
    EXPECT_NEAR(direction_to_latlong({0, 1, 0}).u, 0.25, 1e-12);
    EXPECT_NEAR(direction_to_latlong({0, -1, 0}).u, 0.75, 1e-12);
    EXPECT_NEAR(direction_to_latlong({0, 0, 1}).v, 1.0, 1e-12);
    for (double u : {0.1, 0.3, 0.77})
        for (double v : {0.05, 0.5, 0.9}) {
            const LatLongUV back = direction_to_latlong(latlong_to_direction(u, v));
            EXPECT_NEAR(back.u, u, 1e-12);
            EXPECT_NEAR(back.v, v, 1e-12);
        }
}

TEST(LatLong, RowSolidAnglesAreExact) {
    for (int h : {1, 2, 7, 1024, 8192}) {
        const int w = 2 * h;
        double sum = 0.0;
        for (int y = 0; y < h; ++y) sum += w * latlong_row_solid_angle(y, w, h);
        EXPECT_NEAR(sum, 4.0 * kPi, 1e-9);
    }
    // Top row of a 2:1 image of height 8192: (2 pi / W)(1 - cos(pi / H)).
    const int h = 8192, w = 16384;
    const double exact = (2 * kPi / w) * (1 - std::cos(kPi / h));
    EXPECT_NEAR(latlong_row_solid_angle(0, w, h) / exact, 1.0, 1e-9);
}

// The hats of a few texels alone are, to the bit, those of the whole call
// (the hot texels' hats, make_hot_points and remove_hot): first, last and
// middle texels (the wrapped and clamped ends), a repeat, bins that do and
// do not divide the texels, one bin; a texel off the axis is refused.
TEST(LatLong, HatPiecesOfSomeTexelsAreThoseOfTheWholeCall) {
    for (const auto& [texels, bins] : {std::pair{97, 16}, {256, 64}, {300, 1}, {1024, 512}, {5, 8}}) {
        const std::vector<int> only = {texels - 1, 0, texels / 2, 0, 1, texels / 3};
        for (const bool lon : {true, false}) {
            const std::vector<HatPiece> all = lon ? hat_pieces_lon(texels, bins) : hat_pieces_lat(texels, bins);
            const std::vector<HatPiece> some =
                lon ? hat_pieces_lon(texels, bins, only) : hat_pieces_lat(texels, bins, only);
            std::vector<HatPiece> expect;
            for (const HatPiece& p : all)
                if (std::find(only.begin(), only.end(), p.texel) != only.end()) expect.push_back(p);
            ASSERT_EQ(some.size(), expect.size()) << texels << " " << bins << " " << lon;
            ASSERT_GT(some.size(), 0u);
            for (size_t k = 0; k < some.size(); ++k) {
                EXPECT_EQ(some[k].texel, expect[k].texel);
                EXPECT_EQ(some[k].bin, expect[k].bin);
                EXPECT_EQ(std::memcmp(some[k].w, expect[k].w, sizeof(some[k].w)), 0) << texels << " " << bins;
            }
        }
        EXPECT_THROW(hat_pieces_lon(texels, bins, {texels}), std::out_of_range);
        EXPECT_THROW(hat_pieces_lat(texels, bins, {-1}), std::out_of_range);
        EXPECT_TRUE(hat_pieces_lat(texels, bins, {}).empty());
    }
}

TEST(Quadrature, GaussLegendreIsExactForPolynomials) {
    for (int n : {1, 2, 5, 12, 40}) {
        const QuadratureRule r = gauss_legendre(n, 0.0, 2.0);
        for (int deg = 0; deg <= 2 * n - 1; ++deg) {
            double s = 0;
            for (int i = 0; i < n; ++i) s += r.weights[i] * std::pow(r.nodes[i], deg);
            EXPECT_NEAR(s, std::pow(2.0, deg + 1) / (deg + 1), 1e-11 * std::pow(2.0, deg + 1)) << n << " " << deg;
        }
    }
}

TEST(Ggx, SampleAndInvertRoundTrip) {
    for (double alpha : {1e-3, 0.05, 0.3, 1.0})
        for (double u : {0.0, 0.1, 0.5, 0.9, 0.999}) {
            const double c2 = ggx::sample_cos2(alpha, u), s2 = ggx::sample_sin2(alpha, u);
            EXPECT_NEAR(c2 + s2, 1.0, 1e-12);
            EXPECT_NEAR(ggx::invert_sample(alpha, c2, s2), u, 1e-9);
        }
}

TEST(Ggx, DistributionIsNormalised) {
    // integral D(h) cos(theta_h) dh = 1 (midpoint rule in theta_h, fine enough for the peak).
    for (double alpha : {0.02, 0.2, 0.7, 1.0}) {
        const int n = 200000;
        double s = 0;
        for (int i = 0; i < n; ++i) {
            const double t = (i + 0.5) / n * (kPi / 2), c = std::cos(t), sn = std::sin(t);
            s += ggx::pdf_h(alpha, c * c, sn * sn) * 2 * kPi * sn * (kPi / 2) / n;
        }
        EXPECT_NEAR(s, 1.0, 1e-5) << alpha;
    }
}

TEST(Ggx, PrefilterNormaliserMatchesNumericIntegral) {
    for (double alpha : {0.01, 0.1, 0.5, 0.9, 0.97, 1.0}) {
        // Z = integral over w of K = D(h) max(0, n.w), in theta_w with many points.
        const int n = 200000;
        double s = 0;
        for (int i = 0; i < n; ++i) {
            const double t = (i + 0.5) / n * (kPi / 2);
            s += ggx::prefilter_kernel(alpha, 1 - std::cos(t)) * 2 * kPi * std::sin(t) * (kPi / 2) / n;
        }
        EXPECT_NEAR(ggx::prefilter_normalizer(alpha) / s, 1.0, 1e-4) << alpha;
    }
    EXPECT_NEAR(ggx::prefilter_normalizer(1.0), 1.0, 1e-12);  // alpha = 1: (1/pi) cos, integral 1
}

TEST(Basis, OrthonormalEverywhere) {
    for (const Vec3d n : {Vec3d{0, 0, 1}, Vec3d{0, 0, -1}, normalize(Vec3d{1, 2, 3}), normalize(Vec3d{-1e-9, 1, -1e-7})}) {
        Vec3d t, b;
        orthonormal_basis(n, t, b);
        EXPECT_NEAR(dot(t, t), 1, 1e-12);
        EXPECT_NEAR(dot(b, b), 1, 1e-12);
        EXPECT_NEAR(dot(t, b), 0, 1e-12);
        EXPECT_NEAR(dot(t, n), 0, 1e-12);
        EXPECT_NEAR(dot(b, n), 0, 1e-12);
    }
}

TEST(FastMath, AcosWithinItsBound) {
    double worst = 0.0;
    for (int k = -100000; k <= 100000; ++k) {
        const float x = float(k) / 100000.0f;
        worst = std::max(worst, std::fabs(double(fast_acos(x)) - std::acos(double(x))));
    }
    EXPECT_LT(worst, 5e-7);
    EXPECT_NEAR(fast_acos(1.5f), 0.0f, 1e-7f);  // clamped
    EXPECT_NEAR(fast_acos(-1.5f), 3.14159265f, 1e-6f);
}

// acos_float gives float(std::acos(x)) to the bit: 4 million x, random in
// [0.98, 1) (its series) and in [-1, 1], the doubles just below 1 and at
// 0.98, the ends, and angles halfway between two floats.
TEST(FastMath, AcosFloatIsTheLibrarysFloat) {
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> near_one(0.98, 1.0), any(-1.0, 1.0);
    std::vector<double> xs{-1.0, -0.5, 0.0, 0.5, 0.97999999999999998, 0.98, 0.98000000000000009, 1.0};
    double x = 1.0;
    for (int k = 0; k < 100000; ++k) xs.push_back(x = std::nextafter(x, 0.0));
    for (int k = 0; k < 3000000; ++k) xs.push_back(near_one(rng));
    for (int k = 0; k < 900000; ++k) xs.push_back(any(rng));
    // Angles as near halfway between two floats as a double can put them
    // (x = cos of the midpoint), where only the guard keeps the two equal.
    std::uniform_real_distribution<float> angle(1e-4f, 0.2f);
    for (int k = 0; k < 200000; ++k) {
        const float f = angle(rng);
        xs.push_back(std::cos(0.5 * (double(f) + double(std::nextafter(f, 1.0f)))));
    }
    size_t mismatches = 0;
    for (double v : xs) {
        const float a = acos_float(v), b = float(std::acos(v));
        if (std::memcmp(&a, &b, sizeof(a)) != 0 && ++mismatches <= 5)
            ADD_FAILURE() << std::setprecision(17) << "x " << v << ": " << a << " against " << b;
    }
    EXPECT_EQ(mismatches, 0u);
}

TEST(FastMath, Atan2VecMatchesLibm) {
    // Every quadrant, both octants, the reduction's seam (0.66) and the axes.
    double worst = 0.0;
    for (int k = 0; k < 200000; ++k) {
        const double t = -kPi + 2 * kPi * (k + 0.37) / 200000, r = 0.5 + (k % 7);
        const double y = r * std::sin(t), x = r * std::cos(t);
        worst = std::max(worst, std::fabs(atan2_vec(y, x) - std::atan2(y, x)));
    }
    for (double a : {0.0, 0.66, 0.6600000001, 1.0, 1e-300}) {
        worst = std::max(worst, std::fabs(atan2_vec(a, 1.0) - std::atan2(a, 1.0)));
        worst = std::max(worst, std::fabs(atan2_vec(-1.0, -a) - std::atan2(-1.0, -a)));
    }
    EXPECT_LT(worst, 1e-15);
    EXPECT_EQ(atan2_vec(0.0, 0.0), 0.0);
    EXPECT_DOUBLE_EQ(atan2_vec(1.0, 0.0), kPi / 2);
    EXPECT_DOUBLE_EQ(atan2_vec(0.0, -1.0), kPi);
}
