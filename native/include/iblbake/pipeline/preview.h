// preview.png: a contact sheet of a bake to look at, drawn by our own code so
// the CLI (--preview) and the Blender add-on make the same sheet. Pure: a
// BakeResult in, an image out; writing it is write.h's write_preview().
// It lives in pipeline/, not image/: the sheet is a composition of a whole
// bake (its levels, the LUT, spheres shaded through the split sum), and its
// drawing helpers (a bitmap font, rectangles) serve nothing else, so an
// input type of its own in image/ would only copy BakeResult's fields.
//
// Layout, top to bottom: the irradiance cross, the BRDF LUT and a diffuse
// sphere; one row with every baked specular level's cross; a row of metal
// spheres and a row of dielectric spheres, one per level at that level's
// roughness, lit by the bake through the split sum:
//   metal:      Pre(R, r) * (F0 A + B)
//   dielectric: albedo * Irr(N) * (1 - (F0 A + B)) + Pre(R, r) * (F0 A + B)
// with (A, B) from the baked LUT (or Karis' analytic fit when no LUT was
// baked), Irr stored / pi as the bake writes it, an orthographic view along
// engine -Z (Blender's front view: looking along +Y, Z up).
#pragma once
#include <array>
#include <string>

#include "iblbake/bake/bake.h"
#include "iblbake/image/image.h"

namespace iblbake {

struct PreviewOptions {
    int cell = 128;              // column width of one specular level
    float key = 0.5f;            // a white diffuse surface's mean (or the sky's log-average) maps to this
    float exposure_stops = 0.0f; // on top of that
};

// Materials of the sphere rows.
constexpr std::array<float, 3> kPreviewMetalF0 = {0.95f, 0.93f, 0.88f};  // silver-like
constexpr float kPreviewDielectricF0 = 0.04f;
constexpr float kPreviewAlbedo = 0.8f;

// The factor the sheet multiplies radiance by: key / the irradiance's mean
// luminance (else the log-average of the sharpest specular level); 1 for a
// black bake. Then preview_tone() maps it to display values.
double preview_scale(const BakeResult& r, const PreviewOptions& o = {});
// Reinhard's curve with a white point of 4 (x (1 + x / 16) / (1 + x)).
float preview_tone(float x);

// Split-sum shading of one sphere point (engine-space unit normal n, view
// direction v towards the eye) at specular entry `level` (an index into
// r.specular): linear radiance, not scaled. `metal` picks the material.
std::array<float, 3> shade_sphere(const BakeResult& r, size_t level, const std::array<double, 3>& n,
                                  const std::array<double, 3>& v, bool metal);

// The sheet in display-linear values: radiance times preview_scale(), through
// preview_tone() (labels and background included); encode_srgb_in_place
// turns it into what preview.png holds.
Image render_preview(const BakeResult& r, const PreviewOptions& o = {});

// Where things are on the sheet (for tests): the centre and radius of the
// sphere of entry `level` in row `metal` (true) or dielectric (false).
struct SphereSpot {
    int cx = 0, cy = 0, radius = 0;
};
SphereSpot preview_sphere_spot(const BakeResult& r, size_t level, bool metal, const PreviewOptions& o = {});

// Karis' analytic fit of the split-sum (A, B) (Unreal mobile, 2014), for
// bakes written without a LUT: a rough fit (A off by up to about 0.2 at
// mid roughness), enough for a picture.
std::array<float, 2> env_brdf_approx(float ndotv, float roughness);

}  // namespace iblbake
