// The sun as each engine's light (issue 27): sun.json, sun.gltf and the
// light in every preset's convention, from the light ibl/sun.h found. Pure:
// no I/O (the pipeline writes the files).
//
// Conventions (docs/export.md "The sun as a light"):
//   direction        towards the light, unit; light_direction = -direction,
//                    where the light travels (what Babylon, Filament, Bevy and
//                    Unity's rotations take);
//   colour           E / max(E), linear Rec. 709, its brightest channel 1 (the
//                    glTF schema's range), so colour x intensity = E x the
//                    preset's intensity scale, per channel;
//   illuminance_lux  the luminance of E: lux when the source is in nits
//                    (cd/m^2), since integral of L cos(theta) dw of nits is lux.
// A directional light of illuminance E on a white Lambertian surface gives
// E max(0, n.d) / pi: the sun-free environment plus it is the source again.
#pragma once
#include <array>
#include <string>

#include <nlohmann/json.hpp>

#include "iblbake/export/preset.h"
#include "iblbake/ibl/sun.h"

namespace iblbake {

// Colour (brightest channel 1) and that channel's illuminance.
std::array<double, 3> sun_colour(const SunLight& sun);
double sun_intensity(const SunLight& sun);
// CIE 1931 xy of E (linear Rec. 709 primaries, D65 white).
std::array<double, 2> sun_chromaticity(const SunLight& sun);
// Towards the light in a preset's engine world (SPEC section 2's axes, the
// engine's world mirror applied).
Vec3d engine_sun_direction(const SunLight& sun, const Preset& p);
// The unit quaternion (x, y, z, w) turning a glTF node's -Z onto `to`.
std::array<double, 4> quaternion_from_minus_z(const Vec3d& to);

// One engine's light: {preset, engine, direction, light_direction, color,
// intensity, units, api, angular_diameter_deg, world_mirror, verified}.
nlohmann::json engine_light(const SunLight& sun, const Preset& p);
// sun.json (the manifest's `sun` too): found, why, direction (Blender world
// space), elevation and azimuth, angular_diameter_deg, illuminance [R, G, B],
// illuminance_lux, color, chromaticity_xy, irradiance_share, removed_power,
// detection; when found also blender (the Sun lamp), gltf and engines (every
// preset of the table, by name).
nlohmann::json sun_json(const SunLight& sun, const SunCriteria& criteria = {});
// sun.gltf: one node, oriented, holding one KHR_lights_punctual directional
// light (null when nothing was found).
std::string sun_gltf(const SunLight& sun, const std::string& generator);

}  // namespace iblbake
