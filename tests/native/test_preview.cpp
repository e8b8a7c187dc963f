// preview.png's contact sheet: the split-sum spheres against closed forms,
// its scale, its orientation, and the file the pipeline writes.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <unistd.h>

#include "iblbake/bake/bake.h"
#include "iblbake/ibl/brdf_lut.h"
#include "iblbake/io/image_io.h"
#include "iblbake/pipeline/preview.h"
#include "iblbake/pipeline/write.h"
#include "scratch.h"

using namespace iblbake;
namespace fs = std::filesystem;

namespace {

BakeOptions options(int lut_size = 128) {
    BakeOptions o;
    o.face_size = 16;
    o.irradiance_size = 8;
    o.lut_size = lut_size;
    return o;
}

double luminance(const std::array<float, 3>& c) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

}  // namespace

// A constant world of radiance c: Pre = Irr = c, so a metal sphere is
// c (F0 A + B) and a dielectric albedo c (1 - s) + c s with s = 0.04 A + B,
// (A, B) the exact split-sum integrals at the point's NdotV and the level's roughness.
TEST(Preview, SpheresInAConstantWorldAreTheSplitSumClosedForm) {
    const std::array<float, 3> c = {0.2f, 0.5f, 1.5f};
    const BakeResult r = compute_constant_bake(c, options());
    ASSERT_EQ(r.specular.size(), 5u);
    const std::array<double, 3> v = {0.0, 0.0, 1.0};
    for (size_t k = 0; k < r.specular.size(); ++k) {
        for (double px : {0.0, 0.3, -0.55, 0.8}) {
            const double py = 0.2;
            const std::array<double, 3> n = {px, py, std::sqrt(1.0 - px * px - py * py)};
            const double rough = std::max(r.roughness[k], 1e-3);
            const LutValue ab = integrate_brdf(n[2], rough, LutModel::Karis);
            const auto metal = shade_sphere(r, k, n, v, true);
            const auto diel = shade_sphere(r, k, n, v, false);
            const double s = kPreviewDielectricF0 * ab.a + ab.b;
            for (int ch = 0; ch < 3; ++ch) {
                const double want_metal = c[ch] * (kPreviewMetalF0[ch] * ab.a + ab.b);
                const double want_diel = kPreviewAlbedo * c[ch] * (1.0 - s) + c[ch] * s;
                // The LUT is read bilinearly from 128 x 128 texels.
                EXPECT_NEAR(metal[ch], want_metal, 4e-3 * c[ch]) << "level " << k << " x " << px;
                EXPECT_NEAR(diel[ch], want_diel, 4e-3 * c[ch]) << "level " << k << " x " << px;
            }
        }
    }
}

TEST(Preview, WithoutALutTheSpheresUseKarisFit) {
    const std::array<float, 3> c = {1.0f, 1.0f, 1.0f};
    BakeOptions o = options();
    o.lut = false;
    const BakeResult r = compute_constant_bake(c, o);
    ASSERT_FALSE(r.lut.has_value());
    const auto ab = env_brdf_approx(1.0f, float(r.roughness[2]));
    const auto metal = shade_sphere(r, 2, {0, 0, 1}, {0, 0, 1}, true);
    EXPECT_NEAR(metal[0], kPreviewMetalF0[0] * ab[0] + ab[1], 1e-5);
    // A rough fit (good enough for a picture): within 0.2 of the integral here.
    const LutValue exact = integrate_brdf(1.0, r.roughness[2], LutModel::Karis);
    EXPECT_NEAR(ab[0], exact.a, 0.2);
    EXPECT_NEAR(ab[1], exact.b, 0.05);
}

// The sheet shows radiance times preview_scale() through preview_tone(): a
// white diffuse surface in a constant world lands at the key (0.5).
TEST(Preview, SheetPixelsAreTheShadedSpheresScaledAndToned) {
    const std::array<float, 3> c = {0.3f, 0.6f, 0.9f};
    const BakeResult r = compute_constant_bake(c, options());
    const double scale = preview_scale(r);
    EXPECT_NEAR(scale, 0.5 / luminance(c), 1e-6);
    const Image sheet = render_preview(r);
    for (bool metal : {true, false}) {
        for (size_t k : {size_t(0), size_t(2), size_t(4)}) {
            const SphereSpot spot = preview_sphere_spot(r, k, metal);
            const auto want = shade_sphere(r, k, {0, 0, 1}, {0, 0, 1}, metal);
            const float* got = sheet.at(spot.cx, spot.cy);
            for (int ch = 0; ch < 3; ++ch)
                EXPECT_NEAR(got[ch], preview_tone(float(want[ch] * scale)), 5e-3)
                    << (metal ? "metal " : "dielectric ") << k << " channel " << ch;
        }
    }
    EXPECT_LT(preview_tone(0.5f), 0.5f);
    EXPECT_NEAR(preview_tone(4.0f), 1.0f, 1e-6);  // the white point
}

// A world bright above the horizon (Blender +Z, engine +Y) and dark below:
// the mirror sphere is bright on top and dark below, and so is the
// irradiance cross's +Y cell against its -Y cell.
TEST(Preview, UpIsUpOnTheSheet) {
    Image src(64, 32);
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 64; ++x)
            for (int ch = 0; ch < 3; ++ch) src.at(x, y)[ch] = y < 16 ? 1.0f : 0.01f;
    const BakeResult r = compute_bake(src, options(32));
    const Image sheet = render_preview(r);
    const SphereSpot spot = preview_sphere_spot(r, 0, true);
    const float top = sheet.at(spot.cx, spot.cy - spot.radius / 2)[1];
    const float bottom = sheet.at(spot.cx, spot.cy + spot.radius / 2)[1];
    EXPECT_GT(top, 4.0f * bottom);
    EXPECT_GT(bottom, 0.0f);
}

TEST(Preview, WrittenBesideTheBakeWhenAsked) {
    const fs::path dir = scratch::root() / "preview";
    fs::remove_all(dir);
    const BakeResult r = compute_constant_bake({0.5f, 0.5f, 0.5f}, options());
    WriteOptions wo;
    wo.preview = true;
    const auto m = write_bake(r, dir, make_plan(options(), wo), SourceInfo{});
    ASSERT_TRUE(fs::is_regular_file(dir / "preview.png"));
    EXPECT_EQ(m["preview"]["file"], "preview.png");
    EXPECT_EQ(m["encodings"]["preview.png"], "srgb8");
    const io::LoadedImage png = io::read_image((dir / "preview.png").string());  // through OpenImageIO
    const Image sheet = render_preview(r);
    EXPECT_EQ(png.image.width, sheet.width);
    EXPECT_EQ(png.image.height, sheet.height);
    // The file is the sheet, sRGB encoded: decoded back within 8-bit rounding.
    const SphereSpot spot = preview_sphere_spot(r, 1, false);
    for (int ch = 0; ch < 3; ++ch)
        EXPECT_NEAR(png.image.at(spot.cx, spot.cy)[ch], sheet.at(spot.cx, spot.cy)[ch], 0.01);
    wo.preview = false;
    fs::remove_all(dir);
    const auto m2 = write_bake(r, dir, make_plan(options(), wo), SourceInfo{});
    EXPECT_FALSE(fs::exists(dir / "preview.png"));
    EXPECT_FALSE(m2.contains("preview"));
    fs::remove_all(dir);
}
