// The sun as a light (issue 27): finding the dominant compact light source of
// a lat-long source, and the source without it. Pure math over an image, no
// I/O; directions are Blender world space (SPEC.md section 1), the engines'
// spaces are export/'s business (export/sun.h).
//
// Detection, on the luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of the
// texels (linear Rec. 709), in this order; the first test that fails is the
// plain reason given (SunLight::why):
//   1. light: the brightest texel's luminance P is finite and positive;
//   2. compact: the texels of at least P / 2 connected to it (the core) fit
//      a disc of max_core_diameter_deg (5 degrees: the real sun is 0.53, a
//      blurred or low-resolution HDRI makes it a few texels);
//   3. bright: P is at least min_contrast (50) times the median luminance of
//      the ring from 3 to 6 core radii around it (at least 3 and 6 texels):
//      an overcast sky's brightest texel is a few times its surroundings;
//   4. alone: no texel farther than rival_distance_deg (10 degrees) from it
//      reaches max_rival (a tenth) of P: an interior's ceiling lights, a
//      night's street lamps are several sources of one brightness, and none
//      of them is "the" sun.
// Measured on Blender's eight studio-light worlds: city, forest, sunrise and
// sunset pass (their brightest other texel is 0.04 %, 3 %, 0.05 % and 0.2 %
// of the sun); courtyard, interior, night and studio fail test 4 (47 %,
// 98 %, 89 %, 97 %) and studio test 2 too (its softboxes are 6 degrees).
//
// Removal: the sun's texels are those connected to the brightest whose
// luminance exceeds mask_factor (4) times the ring's median, within the
// ring's outer radius, and their neighbours (the bilinear L of SPEC section
// 1 spreads a texel to its neighbours' centres). Each channel of those
// texels is replaced by the harmonic interpolation of the texels around them
// (the Laplace equation on the sphere, discretised below), then kept at most
// at its own value: the estimate is smooth, continuous with its
// surroundings (no ring), never below their smallest value nor above their
// largest (the maximum principle), and the removed radiance is never
// negative. The light is what was removed:
//   direction  d = normalize(integral of dY(w) w dw), the luminance-weighted
//              centroid on the sphere of the removed radiance dL;
//   E_c        = integral of dL_c(w) (d.w) dw, the illuminance it gives at
//              normal incidence, per channel, in the source's units (lux
//              when the radiance is in nits);
//   diameter   of the disc whose solid angle is that of the region where
//              the removed luminance is at least half its largest (a
//              uniform disc blurred by the bilinear reconstruction keeps its
//              edge at half height);
// all three over SPEC's bilinear L, so that the light and the sun-free
// environment add up to the source: dL is a sum of texel values times the
// reconstruction's hats, and each hat's integrals of 1 and w are exact
// (math/latlong.h's hat pieces).
#pragma once
#include <array>
#include <string>
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/math/vec3.h"

namespace iblbake {

struct SunCriteria {
    double max_core_diameter_deg = 5.0;
    double min_contrast = 50.0;
    double rival_distance_deg = 10.0;
    double max_rival = 0.1;
    double mask_factor = 4.0;
};

// Luminance of linear Rec. 709 RGB.
inline double rec709_luminance(const double rgb[3]) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }
inline double rec709_luminance(const std::array<double, 3>& rgb) { return rec709_luminance(rgb.data()); }

struct SunLight {
    bool found = false;
    // Found: a sentence on what was found; else which test failed and why,
    // in words (e.g. "no dominant source: a texel 58 degrees away is 98 % as
    // bright as the brightest").
    std::string why;
    Vec3d direction{0.0, 0.0, 1.0};  // towards the light, Blender world space (unit)
    double angular_diameter_deg = 0.0;
    std::array<double, 3> illuminance{};  // E_c at normal incidence
    // The light's share of the illuminance on a surface facing it:
    // E_Y / (E_Y + integral of the sun-free L_Y max(0, d.w) dw).
    double irradiance_share = 0.0;
    // What the tests measured.
    double peak_luminance = 0.0, ring_luminance = 0.0, rival_luminance = 0.0, rival_distance_deg = 0.0;
    double core_diameter_deg = 0.0;                  // from the core's texels (test 2)
    std::array<double, 3> removed_power{};           // integral of dL_c over the sphere
    size_t texels = 0;                               // texels replaced
    double elevation_deg() const;                    // above the horizon (Blender's XY plane)
};

// The texels a split replaces and their sun-free values.
struct SunTexel {
    int x, y;
    float rgb[3];
};
struct SunSplit {
    SunLight light;
    std::vector<SunTexel> texels;  // empty when nothing was found; ordered by row
    std::vector<int> rows;         // the rows they are in, ascending
};

// Finds the sun of `img` (a Blender lat-long, clean: finite, >= 0) and, when
// there is one, the sun-free values of its texels.
SunSplit split_sun(ImageView img, const SunCriteria& criteria = {});

// The split applied: in place, or as a view of `img` whose changed rows are
// copies in `store` (the others `img`'s own, through `row_table`).
void apply_sun_split(Image& img, const SunSplit& split);
ImageView sun_free_view(ImageView img, const SunSplit& split, std::vector<float>& store,
                        std::vector<const float*>& row_table);

}  // namespace iblbake
