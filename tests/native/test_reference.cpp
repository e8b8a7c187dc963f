// The exhaustive reference itself (tests/native/reference.h) against closed
// forms: the quadrature of SPEC's bilinear L must be far more accurate than
// anything it judges.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "iblbake/ibl/source.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/ggx.h"
#include "reference.h"

using namespace iblbake;

TEST(Reference, KernelIntegralIsTheClosedForm) {
    // The quadrature's integral of K alone is Z(alpha) whatever the source.
    const Image src = ref::constant_source(256, 128, 1.0f);
    const ref::TexelTable t = ref::texel_table(src);
    double worst = 0;
    for (double r : {0.1, 0.125, 0.25, 0.5, 0.75, 1.0})
        for (const Vec3d& n : {texel_direction(0, 3, 5, 8), texel_direction(2, 4, 4, 8), texel_direction(5, 0, 7, 8)}) {
            const double z = ggx::prefilter_normalizer(r * r);
            EXPECT_NEAR(ref::kernel_integral(t, n, r) / z, 1.0, 2e-6) << "r " << r;
            worst = std::max(worst, std::fabs(ref::kernel_integral(t, n, r) / z - 1));
        }
    std::printf("[reference: kernel integral against Z(alpha)] worst relative error %.2e\n", worst);
}

TEST(Reference, ConstantWorld) {
    const Image src = ref::constant_source(64, 32, 2.0f);
    const ref::TexelTable t = ref::texel_table(src);
    for (int f = 0; f < 6; ++f) {
        const Vec3d n = texel_direction(f, 1, 2, 4);
        EXPECT_NEAR(ref::irradiance(t, n)[1], 2.0, 1e-6);
        EXPECT_NEAR(ref::prefiltered(t, n, 0.3)[2], 2.0, 1e-9);
    }
    EXPECT_NEAR(ref::mean_radiance(t)[0], 2.0, 1e-6);
}

TEST(Reference, BilinearIsTheLimitOfFinerTexelConstantGrids) {
    // A coarse sun source; L sampled on 8x and 16x finer grids and summed as
    // texel-constant points approaches the bilinear integral at second order.
    const Image src = ref::sun_source(64, 32, {0.4, 0.6, 0.3}, 4.0, 100.0f, 0.3f);
    const ref::TexelTable t = ref::texel_table(src);
    const Image f8 = resample_latlong(src, 512, 256), f16 = resample_latlong(src, 1024, 512);
    const Vec3d sun = blender_to_engine(normalize(Vec3d{0.4, 0.6, 0.3}));
    for (const Vec3d& n : {sun, normalize(sun + Vec3d{0.1, 0.05, 0.0}), normalize(sun + Vec3d{0.0, 0.6, 0.3})})
        for (double r : {0.25, 0.5, 1.0}) {
            const double b = ref::prefiltered(t, n, r)[0];
            const double e8 = ref::prefiltered_constant(f8, n, r)[0] / b - 1;
            const double e16 = ref::prefiltered_constant(f16, n, r)[0] / b - 1;
            EXPECT_LT(std::fabs(e16), 2e-3) << r;
            EXPECT_LT(std::fabs(e16), 0.4 * std::fabs(e8) + 1e-6) << r;  // second order: about 1/4
            std::printf("[reference: bilinear vs texel-constant on finer grids, r %.2f] 8x %.2e, 16x %.2e\n", r, e8, e16);
        }
    for (const Vec3d& n : {sun, -sun, texel_direction(1, 3, 3, 8)}) {
        const double b = ref::irradiance(t, n)[0];
        EXPECT_NEAR(ref::irradiance_constant(f16, n)[0] / b, 1.0, 1e-3);
    }
}
