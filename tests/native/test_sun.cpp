// The sun as a light (issue 27): detection, the sun-free source, energy.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "iblbake/bake/bake.h"
#include "iblbake/ibl/source.h"
#include "iblbake/ibl/sun.h"
#include "iblbake/io/image_io.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/latlong.h"
#include "reference.h"

using namespace iblbake;

namespace {

constexpr double kDeg = kPi / 180.0;

Vec3d blender_dir(double elevation_deg, double azimuth_deg) {
    const double e = elevation_deg * kDeg, a = azimuth_deg * kDeg;
    return {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
}

// A smooth sky, brighter overhead and bluer: (0.6 + 0.4 z) (1, 1.05, 1.2).
void sky_at(const Vec3d& d, double out[3]) {
    const double b = 0.6 + 0.4 * d.z;
    out[0] = b, out[1] = 1.05 * b, out[2] = 1.2 * b;
}

// The sky plus a uniform disc of radiance `sun` (per channel) and angular
// radius `radius_deg` around `centre`, each texel holding its exact mean
// over the texel (16 x 16 points weighted by cos(lat) where the disc's edge
// crosses it): the disc's illuminance at normal incidence is
// sun pi sin^2(radius) exactly.
Image disc_over_sky(int w, int h, const Vec3d& centre, double radius_deg, const double sun[3]) {
    Image img(w, h);
    const double cr = std::cos(radius_deg * kDeg);
    const double margin = std::cos((radius_deg + 3.0 * 360.0 / w) * kDeg);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Vec3d t = latlong_texel_direction(x, y, w, h);
            double s[3];
            sky_at(t, s);
            double cover = 0.0;
            if (dot(t, centre) > margin) {
                double in = 0.0, all = 0.0;
                for (int j = 0; j < 16; ++j)
                    for (int i = 0; i < 16; ++i) {
                        const double u = (x + (i + 0.5) / 16) / w, v = 1.0 - (y + (j + 0.5) / 16) / h;
                        const double wt = std::cos((v - 0.5) * kPi);
                        all += wt;
                        if (dot(latlong_to_direction(u, v), centre) >= cr) in += wt;
                    }
                cover = in / all;
            }
            for (int c = 0; c < 3; ++c) img.at(x, y)[c] = float(s[c] + sun[c] * cover);
        }
    return img;
}

// (1/pi) integral over the disc of sun max(0, n.w) dw (engine n): the disc's
// own cosine integral, by a polar rule on the cap (no point approximation).
double disc_irradiance(const Vec3d& engine_n, const Vec3d& centre, double radius_deg, double sun) {
    const Vec3d c = blender_to_engine(centre);
    Vec3d t, b;
    orthonormal_basis(c, t, b);
    const double r = radius_deg * kDeg;
    const int nr = 64, np = 128;
    double sum = 0.0;
    for (int i = 0; i < nr; ++i) {
        // theta in [0, r], dw = sin(theta) dtheta dphi (midpoint rule)
        const double th = (i + 0.5) * r / nr;
        for (int k = 0; k < np; ++k) {
            const double ph = (k + 0.5) * 2.0 * kPi / np;
            const Vec3d w = c * std::cos(th) + (t * std::cos(ph) + b * std::sin(ph)) * std::sin(th);
            sum += std::max(0.0, dot(engine_n, w)) * std::sin(th);
        }
    }
    return sun * sum * (r / nr) * (2.0 * kPi / np) / kPi;
}

double angle_deg(const Vec3d& a, const Vec3d& b) {
    return std::atan2(length(cross(a, b)), dot(a, b)) / kDeg;
}

Image sun_free(const Image& src, const SunSplit& split) {
    Image out = src;
    apply_sun_split(out, split);
    return out;
}

// The ring test: no sun-free texel within one diameter of the light
// above twice the brightest sun-free texel 1 to 3 diameters away (luminance).
void expect_no_hole_or_ring(const Image& free, const SunLight& sun) {
    const double dia = std::max(sun.angular_diameter_deg, 180.0 / free.height);
    double inner = 0.0, ring = 0.0;
    for (int y = 0; y < free.height; ++y)
        for (int x = 0; x < free.width; ++x) {
            const double a = angle_deg(latlong_texel_direction(x, y, free.width, free.height), sun.direction);
            const float* p = free.at(x, y);
            const double l = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
            for (int c = 0; c < 3; ++c) EXPECT_GE(p[c], 0.0f);
            if (a < dia) inner = std::max(inner, l);
            else if (a <= 3.0 * dia) ring = std::max(ring, l);
        }
    std::printf("  brightest sun-free texel within 1 diameter %.4g, within 1-3 diameters %.4g\n", inner, ring);
    EXPECT_GT(ring, 0.0);
    EXPECT_LE(inner, 2.0 * ring);
}

// E_c against the reference integrator (SPEC's bilinear L, every texel):
// pi (Irr_source(d) - Irr_sunfree(d)) is the removed light's cosine integral,
// per channel within tol of E's largest channel (a channel the sun does not
// outshine the sky in, sunset's blue, has nothing removed and E_c = 0).
void expect_energy_kept(const Image& src, const Image& free, const SunLight& sun, double tol) {
    const Vec3d n = blender_to_engine(sun.direction);
    const ref::Rgb a = ref::irradiance(src, n), b = ref::irradiance(free, n);
    const double top = std::max({sun.illuminance[0], sun.illuminance[1], sun.illuminance[2]});
    for (int c = 0; c < 3; ++c) {
        const double removed = kPi * (a[c] - b[c]);
        std::printf("  channel %d: removed %.7g, E %.7g (%.2e of the largest E)\n", c, removed, sun.illuminance[c],
                    (removed - sun.illuminance[c]) / top);
        EXPECT_NEAR(removed, sun.illuminance[c], tol * top) << "channel " << c;
        // and what a light of illuminance E adds back at normal incidence
        EXPECT_NEAR((b[c] + sun.illuminance[c] / kPi) / a[c], 1.0, tol) << "channel " << c;
    }
}

void report(const char* name, const SunLight& s) {
    std::printf("%s: found %d (%s)\n  direction (%.6f, %.6f, %.6f), elevation %.3f, diameter %.4f deg, E (%.6g, %.6g, "
                "%.6g), share %.4f, removed power (%.6g, %.6g, %.6g), %zu texels\n",
                name, int(s.found), s.why.c_str(), s.direction.x, s.direction.y, s.direction.z, s.elevation_deg(),
                s.angular_diameter_deg, s.illuminance[0], s.illuminance[1], s.illuminance[2], s.irradiance_share,
                s.removed_power[0], s.removed_power[1], s.removed_power[2], s.texels);
}

std::string studio_light(const char* name) {
    const std::string p = std::string("/usr/share/blender/datafiles/studiolights/world/") + name;
    return std::filesystem::exists(p) ? p : std::string();
}

}  // namespace

// A disc of known centre, diameter and energy over a smooth sky: direction
// within 0.05 degrees, diameter within 5 %, E within 0.5 %, energy kept
// within 0.1 %, and every irradiance texel of the sun-free bake plus the
// disc's own cosine integral equals the source's bake within 0.5 %.
TEST(Sun, SyntheticDiscFoundMeasuredAndRemoved) {
    const Vec3d centre = blender_dir(34.0, 40.0);
    const double radius = 1.0, sun[3] = {3000.0, 2700.0, 2250.0};
    const Image src = disc_over_sky(1024, 512, centre, radius, sun);
    const SunSplit split = split_sun(src);
    const SunLight& s = split.light;
    report("synthetic disc", s);
    ASSERT_TRUE(s.found) << s.why;
    EXPECT_LT(angle_deg(s.direction, centre), 0.05);
    EXPECT_NEAR(s.angular_diameter_deg / (2.0 * radius), 1.0, 0.05);
    const double cap = kPi * std::pow(std::sin(radius * kDeg), 2.0);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(s.illuminance[c] / (sun[c] * cap), 1.0, 0.005) << c;
    std::printf("  E / exact: %.5f %.5f %.5f; direction off by %.4f deg\n", s.illuminance[0] / (sun[0] * cap),
                s.illuminance[1] / (sun[1] * cap), s.illuminance[2] / (sun[2] * cap), angle_deg(s.direction, centre));
    const Image free = sun_free(src, split);
    expect_energy_kept(src, free, s, 1e-3);
    expect_no_hole_or_ring(free, s);

    // The bakes: every irradiance texel.
    BakeOptions o;
    o.face_size = 16;
    o.irradiance_size = 16;
    o.specular = false;
    o.lut = false;
    const BakeResult orig = compute_bake(src, o);
    o.sun = SunMode::Split;
    const BakeResult split_bake = compute_bake(src, o);
    ASSERT_TRUE(split_bake.sun && split_bake.sun->found);
    EXPECT_EQ(split_bake.sun->illuminance, s.illuminance);
    double worst = 0.0;
    const int n = o.irradiance_size;
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const Vec3d dir = texel_direction(f, i, j, n);
                for (int c = 0; c < 3; ++c) {
                    const double want = orig.irradiance->at(f, i, j)[c];
                    const double got = split_bake.irradiance->at(f, i, j)[c] + disc_irradiance(dir, centre, radius, sun[c]);
                    worst = std::max(worst, std::fabs(got / want - 1.0));
                }
            }
    std::printf("  Irr_sunfree + disc vs Irr_source: largest relative difference %.3g over %d texels\n", worst,
                6 * n * n);
    EXPECT_LT(worst, 0.005);
    // The sun-free bake's SH is that of the sun-free source.
    const auto sh = project_sh9_bilinear(free, 2);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(split_bake.sh9[c][0], sh[c][0], 1e-6 * std::fabs(sh[c][0]));
}

// Skies without a sun split nothing, and say why.
TEST(Sun, NothingSplitWithoutASun) {
    // Overcast: a smooth sky.
    Image overcast(512, 256);
    for (int y = 0; y < overcast.height; ++y)
        for (int x = 0; x < overcast.width; ++x) {
            double s[3];
            sky_at(latlong_texel_direction(x, y, 512, 256), s);
            for (int c = 0; c < 3; ++c) overcast.at(x, y)[c] = float(s[c]);
        }
    SunSplit split = split_sun(overcast);
    report("overcast", split.light);
    EXPECT_FALSE(split.light.found);
    EXPECT_TRUE(split.texels.empty());
    EXPECT_NE(split.light.why.find("no compact source"), std::string::npos) << split.light.why;
    // A bright patch of 3 degrees, 5 times the sky: compact, not bright.
    Image patch = overcast;
    const Vec3d pc = blender_dir(50.0, 100.0);
    for (int y = 0; y < patch.height; ++y)
        for (int x = 0; x < patch.width; ++x)
            if (angle_deg(latlong_texel_direction(x, y, 512, 256), pc) < 1.5)
                for (int k = 0; k < 3; ++k) patch.at(x, y)[k] *= 5.0f;
    split = split_sun(patch);
    report("patch", split.light);
    EXPECT_FALSE(split.light.found);
    EXPECT_NE(split.light.why.find("no bright source"), std::string::npos) << split.light.why;
    // A broad glow (40 degrees across) is not compact.
    Image glow = overcast;
    const Vec3d c = blender_dir(20.0, -30.0);
    for (int y = 0; y < glow.height; ++y)
        for (int x = 0; x < glow.width; ++x) {
            const double a = angle_deg(latlong_texel_direction(x, y, 512, 256), c);
            for (int k = 0; k < 3; ++k) glow.at(x, y)[k] += float(1000.0 * std::exp(-a * a / 400.0));
        }
    split = split_sun(glow);
    report("glow", split.light);
    EXPECT_FALSE(split.light.found);
    EXPECT_NE(split.light.why.find("no compact source"), std::string::npos) << split.light.why;
    // Two lamps of one brightness: neither is the sun.
    Image lamps = overcast;
    lamps.at(100, 60)[0] = lamps.at(100, 60)[1] = lamps.at(100, 60)[2] = 5000.0f;
    lamps.at(300, 70)[0] = lamps.at(300, 70)[1] = lamps.at(300, 70)[2] = 4000.0f;
    split = split_sun(lamps);
    report("two lamps", split.light);
    EXPECT_FALSE(split.light.found);
    EXPECT_NE(split.light.why.find("no dominant source"), std::string::npos) << split.light.why;
    // Black.
    split = split_sun(Image(64, 32));
    EXPECT_FALSE(split.light.found);
    // A bake asked to split a sunless sky changes nothing.
    BakeOptions o;
    o.face_size = 16;
    o.irradiance_size = 8;
    o.lut = false;
    const BakeResult a = compute_bake(overcast, o);
    o.sun = SunMode::Split;
    const BakeResult b = compute_bake(overcast, o);
    ASSERT_TRUE(b.sun);
    EXPECT_FALSE(b.sun->found);
    EXPECT_EQ(a.irradiance->pixels, b.irradiance->pixels);
    for (size_t k = 0; k < a.specular.size(); ++k) EXPECT_EQ(a.specular[k].pixels, b.specular[k].pixels);
}

// Blender's studio lights: the four with a sun are found, the interior, the
// night's street lamps, the courtyard and the studio's softboxes are not.
TEST(Sun, BlenderStudioLights) {
    for (const char* name : {"city.exr", "courtyard.exr", "forest.exr", "interior.exr", "night.exr", "studio.exr",
                             "sunrise.exr", "sunset.exr"}) {
        const std::string path = studio_light(name);
        if (path.empty()) GTEST_SKIP() << "Blender's studio lights are not installed";
        Image src = io::read_image(path).image;
        sanitize(src);  // as a bake cleans it
        const SunSplit split = split_sun(src);
        report(name, split.light);
        const std::string n = name;
        const bool sun = n == "city.exr" || n == "forest.exr" || n == "sunrise.exr" || n == "sunset.exr";
        EXPECT_EQ(split.light.found, sun) << name << ": " << split.light.why;
    }
}

// sunset.exr: per-channel energy conservation (0.1 %) and the ring test.
TEST(Sun, SunsetEnergyAndRing) {
    const std::string path = studio_light("sunset.exr");
    if (path.empty()) GTEST_SKIP() << "Blender's studio lights are not installed";
    Image src = io::read_image(path).image;
    sanitize(src);  // as a bake cleans it (sunset.exr holds a few negative values)
    const SunSplit split = split_sun(src);
    report("sunset.exr", split.light);
    ASSERT_TRUE(split.light.found) << split.light.why;
    const Image free = sun_free(src, split);
    expect_energy_kept(src, free, split.light, 1e-3);
    expect_no_hole_or_ring(free, split.light);
}
