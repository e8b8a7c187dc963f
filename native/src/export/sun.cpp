#include "iblbake/export/sun.h"

#include <algorithm>
#include <cmath>

#include "iblbake/math/cube.h"

namespace iblbake {

using nlohmann::json;

namespace {

constexpr double kDeg = kPi / 180.0;

json vec(const Vec3d& v) { return json::array({v.x, v.y, v.z}); }

// Blender's rotation_euler (XYZ: R = Rz Ry Rx) of the tilt that turns the
// lamp's +Z onto d (a Sun lamp shines along its -Z).
std::array<double, 3> blender_euler_deg(const Vec3d& d) {
    // The rotation about the axis z x d by the angle between them (Rodrigues).
    const Vec3d z{0.0, 0.0, 1.0};
    Vec3d axis = cross(z, d);
    const double s = length(axis), c = std::clamp(dot(z, d), -1.0, 1.0);
    if (s < 1e-12) axis = {1.0, 0.0, 0.0};
    else axis = axis / s;
    const double a = std::atan2(s, c), ca = std::cos(a), sa = std::sin(a), t = 1.0 - ca;
    const double r20 = t * axis.x * axis.z - sa * axis.y, r21 = t * axis.y * axis.z + sa * axis.x,
                 r22 = t * axis.z * axis.z + ca;
    const double r10 = t * axis.x * axis.y + sa * axis.z, r00 = t * axis.x * axis.x + ca;
    return {std::atan2(r21, r22) / kDeg, std::asin(std::clamp(-r20, -1.0, 1.0)) / kDeg, std::atan2(r10, r00) / kDeg};
}

}  // namespace

std::array<double, 3> sun_colour(const SunLight& sun) {
    const double m = sun_intensity(sun);
    if (!(m > 0.0)) return {1.0, 1.0, 1.0};
    return {sun.illuminance[0] / m, sun.illuminance[1] / m, sun.illuminance[2] / m};
}

double sun_intensity(const SunLight& sun) {
    return std::max({sun.illuminance[0], sun.illuminance[1], sun.illuminance[2], 0.0});
}

std::array<double, 2> sun_chromaticity(const SunLight& sun) {
    const auto& e = sun.illuminance;
    const double x = 0.4124 * e[0] + 0.3576 * e[1] + 0.1805 * e[2];
    const double y = 0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2];
    const double z = 0.0193 * e[0] + 0.1192 * e[1] + 0.9505 * e[2];
    const double sum = x + y + z;
    if (!(sum > 0.0)) return {0.3127, 0.3290};  // D65
    return {x / sum, y / sum};
}

Vec3d engine_sun_direction(const SunLight& sun, const Preset& p) {
    Vec3d d = blender_to_engine(sun.direction);
    if (p.light.world == Mirror::X) d.x = -d.x;
    if (p.light.world == Mirror::Z) d.z = -d.z;
    return d;
}

std::array<double, 4> quaternion_from_minus_z(const Vec3d& to) {
    const Vec3d from{0.0, 0.0, -1.0};
    const Vec3d t = normalize(to);
    const double c = dot(from, t);
    if (c < -1.0 + 1e-12) return {1.0, 0.0, 0.0, 0.0};  // half a turn about X
    const Vec3d a = cross(from, t);
    const double w = 1.0 + c, n = std::sqrt(dot(a, a) + w * w);
    return {a.x / n, a.y / n, a.z / n, w / n};
}

json engine_light(const SunLight& sun, const Preset& p) {
    const Vec3d d = engine_sun_direction(sun, p);
    const auto c = sun_colour(sun);
    return {{"preset", p.name},
            {"engine", p.description},
            {"direction", vec(d)},
            {"light_direction", vec(-d)},
            {"color", c},
            {"intensity", sun_intensity(sun) * p.light.intensity_scale},
            {"units", p.light.units},
            {"api", p.light.api},
            {"angular_diameter_deg", sun.angular_diameter_deg},
            {"world_mirror", mirror_name(p.light.world)},
            {"verified", p.light.verified}};
}

json sun_json(const SunLight& sun, const SunCriteria& criteria) {
    json det = {{"peak_luminance", sun.peak_luminance},
                {"ring_luminance", sun.ring_luminance},
                {"contrast", sun.ring_luminance > 0.0 ? json(sun.peak_luminance / sun.ring_luminance) : json(nullptr)},
                {"rival_luminance", sun.rival_luminance},
                {"rival_distance_deg", sun.rival_distance_deg},
                {"core_diameter_deg", sun.core_diameter_deg},
                {"texels_replaced", sun.texels},
                {"criteria", {{"max_core_diameter_deg", criteria.max_core_diameter_deg},
                              {"min_contrast", criteria.min_contrast},
                              {"rival_distance_deg", criteria.rival_distance_deg},
                              {"max_rival", criteria.max_rival},
                              {"mask_factor", criteria.mask_factor}}}};
    json j = {{"found", sun.found}, {"why", sun.why}};
    if (!sun.found) {
        j["detection"] = det;
        return j;
    }
    const auto c = sun_colour(sun);
    const double az = std::atan2(sun.direction.y, sun.direction.x) / kDeg;
    j["direction"] = vec(sun.direction);
    j["direction_space"] = "Blender world (+Z up), towards the light";
    j["elevation_deg"] = sun.elevation_deg();
    j["azimuth_deg"] = az;
    j["angular_diameter_deg"] = sun.angular_diameter_deg;
    j["illuminance"] = sun.illuminance;
    j["illuminance_note"] =
        "E_c = integral of (L_source - L_sunfree)_c cos(theta) dw at normal incidence, in the source's units "
        "(lux when the source is in nits)";
    j["illuminance_lux"] = rec709_luminance(sun.illuminance);
    j["color"] = c;
    j["chromaticity_xy"] = sun_chromaticity(sun);
    j["irradiance_share"] = sun.irradiance_share;
    j["removed_power"] = sun.removed_power;
    j["detection"] = det;
    j["files"] = {{"gltf", "sun.gltf"}};
    j["blender"] = {{"type", "SUN"},
                    {"strength", sun_intensity(sun)},
                    {"color", c},
                    {"angle_deg", sun.angular_diameter_deg},
                    {"rotation_euler_deg", blender_euler_deg(sun.direction)},
                    {"note", "Sun lamp: Strength in W/m^2 is its irradiance, so Strength x colour = E; it shines "
                             "along its local -Z, here turned onto -direction"}};
    const Vec3d g = blender_to_engine(sun.direction);
    j["gltf"] = {{"direction", vec(g)},
                 {"light_direction", vec(-g)},
                 {"rotation", quaternion_from_minus_z(-g)},
                 {"color", c},
                 {"intensity", sun_intensity(sun)},
                 {"units", "lux (KHR_lights_punctual: colour x intensity)"}};
    json engines = json::object();
    for (const Preset& p : preset_table()) engines[p.name] = engine_light(sun, p);
    j["engines"] = engines;
    return j;
}

std::string sun_gltf(const SunLight& sun, const std::string& generator) {
    if (!sun.found) return {};
    const Vec3d g = blender_to_engine(sun.direction);
    json light = {{"type", "directional"}, {"name", "sun"}, {"color", sun_colour(sun)}, {"intensity", sun_intensity(sun)}};
    json node = {{"name", "sun"},
                 {"rotation", quaternion_from_minus_z(-g)},
                 {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}},
                 {"extras", {{"angular_diameter_deg", sun.angular_diameter_deg},
                             {"illuminance", sun.illuminance},
                             {"irradiance_share", sun.irradiance_share}}}};
    json gltf = {{"asset", {{"version", "2.0"}, {"generator", generator}}},
                 {"extensionsUsed", {"KHR_lights_punctual"}},
                 {"extensions", {{"KHR_lights_punctual", {{"lights", json::array({light})}}}}},
                 {"scene", 0},
                 {"scenes", json::array({{{"name", "sun"}, {"nodes", {0}}}})},
                 {"nodes", json::array({node})}};
    return gltf.dump(2) + "\n";
}

}  // namespace iblbake
