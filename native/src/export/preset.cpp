#include "iblbake/export/preset.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace iblbake {

namespace {

using PF = PixelFormat;

std::vector<Preset> make_table() {
    std::vector<Preset> t;
    {
        Preset p;
        p.name = "three";
        p.description = "three.js r16x+ (scene.environment with isPMREMTexture = true)";
        p.container = Container::Ktx2;
        p.format = PF::Rgba16f;
        p.formats = {PF::Rgba16f, PF::Rgba32f};
        p.mirror = Mirror::X;
        p.curve = RoughnessCurve::Filament;
        p.smallest = 16;
        p.diffuse = DiffuseForm::TopLevel;
        p.sh = ShForm::Raw;
        p.lod_formula = "lod = T r (2 - r), T = mip count - 1 (three's roughnessToMip, ENVMAP_MAX_LOD)";
        p.diffuse_note = "the top level T (r = 1) is Irr; three reads it as irradiance (getIBLIrradiance). "
                         "Or a THREE.LightProbe from `sh` (adds to the environment's diffuse: use one or the other)";
        p.notes = "r187's KTX2Loader returns an uncompressed cube as a flat texture: rebuild the cube from its "
                  "mipmaps (README). Image cubes are sampled at (-x, y, z): stored x-mirrored";
        p.light = {Mirror::None, 1.0,
                   "DirectionalLight intensity (r155+ physical lighting): colour x intensity is the illuminance at "
                   "normal incidence, lux when the environment is in nits",
                   "const sun = new THREE.DirectionalLight(new THREE.Color(r, g, b), intensity); "
                   "sun.position.set(x, y, z) (direction; its target stays at the origin); scene.add(sun); or "
                   "GLTFLoader on sun.gltf",
                   true};
        t.push_back(p);
    }
    {
        Preset p;
        p.name = "khronos";
        p.description = "glTF Sample Viewer / IBL Sampler, KHR_lights_environment, Cesium";
        p.container = Container::Ktx2;
        p.format = PF::Rgba16f;
        p.formats = {PF::Rgba16f, PF::Rgba32f, PF::E5b9g9r9};
        p.mirror = Mirror::None;
        p.curve = RoughnessCurve::Linear;
        p.smallest = 1;
        p.diffuse = DiffuseForm::Cube;
        p.sh = ShForm::Raw;
        p.lut = true;
        p.lut_model = LutModel::HeightCorrelated;
        p.lod_formula = "lod = T r, T = mip count - 1 (u_MipCount - 1)";
        p.diffuse_note = "diffuse.ktx2: the Lambertian cube, Irr (stored / pi: a white surface reflects the value)";
        p.notes = "SPEC's faces and chain unchanged; brdf_lut.png is the height-correlated Smith LUT, uv = (NdotV, r)";
        p.light = {Mirror::None, 1.0, "KHR_lights_punctual directional light: intensity in lux (colour x intensity)",
                   "sun.gltf: one node whose -Z is light_direction, a KHR_lights_punctual directional light", false};
        t.push_back(p);
    }
    {
        Preset p;
        p.name = "bevy";
        p.description = "Bevy EnvironmentMapLight (features ktx2, zstd)";
        p.container = Container::Ktx2;
        p.format = PF::E5b9g9r9;
        p.formats = {PF::E5b9g9r9, PF::Rgba16f, PF::Rgba32f};
        p.zstd = true;
        p.mirror = Mirror::Z;
        p.curve = RoughnessCurve::Linear;
        p.smallest = 1;
        p.diffuse = DiffuseForm::Cube;
        p.sh = ShForm::None;
        p.lod_formula = "lod = T r, T = textureNumLevels - 1";
        p.diffuse_note = "diffuse.ktx2: the irradiance cube Irr, z-mirrored like the specular";
        p.notes = "Bevy samples cubes at (x, y, -z): stored z-mirrored";
        p.light = {Mirror::None, 1.0, "DirectionalLight illuminance in lux (colour x illuminance)",
                   "DirectionalLight { color: Color::linear_rgb(r, g, b), illuminance, ..default() } with "
                   "Transform::from_translation(Vec3::new(x, y, z)).looking_at(Vec3::ZERO, Vec3::Y)",
                   false};
        t.push_back(p);
    }
    {
        Preset p;
        p.name = "filament";
        p.description = "Filament IndirectLight (createIblFromKtx1 / Ktx1Reader)";
        p.container = Container::Ktx1;
        p.format = PF::Rgba16f;
        p.formats = {PF::Rgba16f, PF::Rgba32f, PF::R11g11b10f};
        p.mirror = Mirror::None;
        p.curve = RoughnessCurve::Filament;
        p.smallest = 16;
        p.diffuse = DiffuseForm::ShKtx1;
        p.sh = ShForm::Filament;
        p.skybox = true;
        p.lod_formula = "lod = T r (2 - r), T = levels - 1 (iblRoughnessOneLevel)";
        p.diffuse_note = "ibl.ktx key `sh`: 27 floats, Filament's pre-scaled irradiance SH (sh9 x k)";
        p.notes = "skybox.ktx holds level 0 alone (createSkyFromKtx1). Filament's web build takes RGBA16F but "
                  "logs that it expects R11F_G11F_B10F (filament:r11g11b10f, about 3 % precision)";
        p.light = {Mirror::None, 1.0, "LightManager intensity in lux (colour x intensity), Type::SUN",
                   "LightManager::Builder(LightManager::Type::SUN).color({r, g, b}).intensity(intensity)"
                   ".direction({lx, ly, lz}).sunAngularRadius(angular_diameter_deg / 2).build(engine, entity)",
                   false};
        t.push_back(p);
    }
    {
        Preset p;
        p.name = "babylon";
        p.description = "Babylon.js CubeTexture.CreateFromPrefilteredData (.env)";
        p.container = Container::Env;
        p.format = PF::RgbdPng;
        p.formats = {PF::RgbdPng};
        p.mirror = Mirror::X;
        p.curve = RoughnessCurve::Babylon;
        p.smallest = 1;
        p.diffuse = DiffuseForm::Polynomial;
        p.sh = ShForm::BabylonPolynomial;
        p.sh_mirrored = true;
        p.lod_formula = "lod = 0.8 log2(N0 alphaG), alphaG = r^2 + 0.0005 for a material of roughness r "
                        "(getLodFromAlphaG x lodGenerationScale 0.8); level m holds the lobe alpha = r_m^2 = "
                        "2^(m/0.8) / N0, as Babylon's own prefiltering";
        p.diffuse_note = "the spherical polynomial in the header (irradiance), from the x-mirrored sh9";
        p.notes = "RGBD PNG faces for every level down to 1 x 1 (Babylon requires the full chain); Babylon's world "
                  "is left-handed and its glTF loader places a glTF scene x-negated (its root: half a turn about Y, "
                  "z scaled by -1): stored x-mirrored, so the environment lights glTF content as SPEC says";
        p.light = {Mirror::X, 1.0,
                   "DirectionalLight intensity, illuminance mode (photometric scale 1): colour x intensity, lux",
                   "const sun = new DirectionalLight('sun', new Vector3(lx, ly, lz), scene); "
                   "sun.diffuse = new Color3(r, g, b); sun.intensity = intensity; or the glTF loader on sun.gltf",
                   false};
        t.push_back(p);
    }
    {
        Preset p;
        p.name = "unity";
        p.description = "Unity (built-in / URP) cubemap imported from DDS, Convolution Type None";
        p.container = Container::Dds;
        p.format = PF::Rgba16f;
        p.formats = {PF::Rgba16f, PF::Rgba32f};
        p.mirror = Mirror::X;
        p.curve = RoughnessCurve::Unity;
        p.smallest = 1;
        p.curve_top = 6;
        p.diffuse = DiffuseForm::Engine;
        p.sh = ShForm::None;
        p.lod_formula = "lod = 6 r (1.7 - 0.7 r) (UNITY_SPECCUBE_LOD_STEPS 6); levels below 6 hold r = 1";
        p.diffuse_note = "Unity computes its ambient SH from the skybox itself";
        p.notes = "left-handed: stored x-mirrored (unverified in a running Unity)";
        p.light = {Mirror::X, 1.0 / 3.14159265358979323846,
                   "Light.intensity of a directional light (built-in / URP: their diffuse BRDF leaves out "
                   "Lambert's 1 / pi, so the intensity is E / pi), colour in linear space",
                   "light.type = LightType.Directional; light.color = new Color(r, g, b); light.intensity = intensity; "
                   "light.transform.rotation = Quaternion.LookRotation(new Vector3(lx, ly, lz))",
                   false};
        t.push_back(p);
    }
    {
        Preset p;
        p.name = "cesium";
        p.description = "CesiumJS ImageBasedLighting (specularEnvironmentMaps, sphericalHarmonicCoefficients)";
        p.container = Container::Ktx2;
        p.format = PF::Rgba16f;
        p.formats = {PF::Rgba16f, PF::Rgba32f};
        p.mirror = Mirror::None;
        p.curve = RoughnessCurve::Linear;
        p.smallest = 1;
        p.diffuse = DiffuseForm::ShManifest;
        p.sh = ShForm::Filament;
        p.lod_formula = "lod = r x maximum LOD, the maximum LOD = levels - 1 (ImageBasedLightingStageFS.glsl)";
        p.diffuse_note = "sphericalHarmonicCoefficients: the manifest's `sh` (Filament's pre-scaled form, which "
                         "czm_sphericalHarmonics evaluates as L00 + L1-1 y + L10 z + L11 x + ...)";
        p.notes = "from CesiumJS's shaders; not rendered in Cesium here: the axes of its IBL reference frame "
                  "(iblReferenceFrameMatrix) are unverified";
        p.light = {Mirror::None, 1.0, "DirectionalLight intensity (colour x intensity); the axes of Cesium's IBL "
                   "frame are unverified",
                   "scene.light = new Cesium.DirectionalLight({ direction: new Cesium.Cartesian3(lx, ly, lz), "
                   "color: new Cesium.Color(r, g, b), intensity })",
                   false};
        t.push_back(p);
    }
    {
        Preset p;
        p.name = "source";
        p.description = "Unreal, Godot 4, O3DE (they refilter the source themselves)";
        p.container = Container::Source;
        p.format = PF::Float32;
        p.formats = {PF::Float32};
        p.mirror = Mirror::None;
        p.curve = RoughnessCurve::None;
        p.smallest = 1;
        p.diffuse = DiffuseForm::Engine;
        p.sh = ShForm::None;
        p.lod_formula = "";
        p.diffuse_note = "the engine computes its own";
        p.notes = "these engines filter IBL at import or at run time, so a prefiltered chain would be filtered "
                  "again: they get the source lat-long (cleaned of NaN, Inf and negative values) as EXR and "
                  "Radiance HDR";
        p.light = {Mirror::None, 1.0, "lux (Unreal's Directional Light, Godot's DirectionalLight3D with physical "
                   "light units): colour x intensity",
                   "import sun.gltf with the engine's glTF importer (it converts the axes); Unreal's Source Angle = "
                   "angular_diameter_deg, Godot's angular_distance = angular_diameter_deg / 2",
                   false};
        t.push_back(p);
    }
    return t;
}

[[noreturn]] void bad(const std::string& what) { throw std::invalid_argument(what); }

PixelFormat format_from_name(const std::string& s, bool& ok) {
    ok = true;
    for (PixelFormat f : {PF::Rgba16f, PF::Rgba32f, PF::E5b9g9r9, PF::R11g11b10f, PF::RgbdPng, PF::Float32})
        if (s == pixel_format_name(f)) return f;
    ok = false;
    return PF::Rgba16f;
}

std::string names(const std::vector<std::string>& v) {
    std::string s;
    for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
    return s;
}

std::string trim(const std::string& s) {
    const size_t a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t");
    return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

std::vector<std::string> preset_names();

}  // namespace

const std::vector<Preset>& preset_table() {
    static const std::vector<Preset> table = make_table();
    return table;
}

namespace {
std::vector<std::string> preset_names() {
    std::vector<std::string> n;
    for (const Preset& p : preset_table()) n.push_back(p.name);
    return n;
}
}  // namespace

const char* container_name(Container c) {
    switch (c) {
        case Container::Ktx2: return "ktx2";
        case Container::Dds: return "dds";
        case Container::Ktx1: return "ktx1";
        case Container::Env: return "env";
        case Container::Source: return "latlong";
    }
    return "?";
}

const char* pixel_format_name(PixelFormat f) {
    switch (f) {
        case PF::Rgba16f: return "rgba16f";
        case PF::Rgba32f: return "rgba32f";
        case PF::E5b9g9r9: return "e5b9g9r9";
        case PF::R11g11b10f: return "r11g11b10f";
        case PF::RgbdPng: return "rgbd-png";
        case PF::Float32: return "float32";
    }
    return "?";
}

const char* mirror_name(Mirror m) { return m == Mirror::X ? "x" : m == Mirror::Z ? "z" : "none"; }

const char* curve_name(RoughnessCurve c) {
    switch (c) {
        case RoughnessCurve::Linear: return "linear";
        case RoughnessCurve::Filament: return "filament";
        case RoughnessCurve::Unity: return "unity";
        case RoughnessCurve::Babylon: return "babylon";
        case RoughnessCurve::None: return "none";
    }
    return "?";
}

const char* diffuse_name(DiffuseForm d) {
    switch (d) {
        case DiffuseForm::Cube: return "cube";
        case DiffuseForm::TopLevel: return "top-level";
        case DiffuseForm::ShManifest: return "sh-manifest";
        case DiffuseForm::ShKtx1: return "sh-ktx1";
        case DiffuseForm::Polynomial: return "polynomial";
        case DiffuseForm::Engine: return "engine";
    }
    return "?";
}

const char* sh_form_name(ShForm s) {
    switch (s) {
        case ShForm::None: return "none";
        case ShForm::Raw: return "sh9";
        case ShForm::Filament: return "filament";
        case ShForm::BabylonPolynomial: return "babylon-polynomial";
    }
    return "?";
}

Preset parse_preset(const std::string& spec_in) {
    const std::string spec = trim(spec_in);
    std::vector<std::string> parts;
    std::stringstream ss(spec);
    for (std::string part; std::getline(ss, part, ':');) parts.push_back(trim(part));
    if (parts.empty() || parts[0].empty()) bad("empty preset name (expected one of " + names(preset_names()) + ")");
    const Preset* row = nullptr;
    std::vector<std::string> known;
    for (const Preset& p : preset_table()) {
        known.push_back(p.name);
        if (p.name == parts[0]) row = &p;
    }
    if (!row) bad("unknown preset '" + parts[0] + "' (expected one of " + names(known) + ")");
    Preset p = *row;
    if (spec.back() == ':') parts.emplace_back();  // "khronos:": getline drops the empty last part
    std::string format_given, zstd_given;           // each may be given once
    auto once = [&](std::string& given, const std::string& m) {
        if (!given.empty())
            bad("preset '" + p.name + "': the modifiers '" + given + "' and '" + m +
                "' contradict each other (give one)");
        given = m;
    };
    for (size_t i = 1; i < parts.size(); ++i) {
        const std::string& m = parts[i];
        if (m.empty()) bad("preset '" + p.name + "': an empty modifier in '" + spec + "' (nothing after a ':')");
        if (m == "zstd" || m == "nozstd") {
            if (p.container != Container::Ktx2)
                bad("preset '" + p.name + "': zstd supercompression applies to KTX2 only");
            once(zstd_given, m);
            p.zstd = m == "zstd";
            continue;
        }
        bool ok = false;
        const PixelFormat f = format_from_name(m, ok);
        std::vector<std::string> allowed;
        for (PixelFormat a : p.formats) allowed.push_back(pixel_format_name(a));
        if (!ok || std::find(p.formats.begin(), p.formats.end(), f) == p.formats.end())
            bad("preset '" + p.name + "': unknown modifier '" + m + "' (expected a format of its " +
                container_name(p.container) + " file: " + names(allowed) +
                (p.container == Container::Ktx2 ? "; or zstd, nozstd" : "") + ")");
        once(format_given, m);
        p.format = f;
    }
    return p;
}

std::vector<Preset> parse_presets(const std::vector<std::string>& specs) {
    std::vector<Preset> out;
    std::set<std::string> seen;
    for (const std::string& s : specs) {
        if (trim(s).empty()) bad("an empty preset (expected one of " + names(preset_names()) + ")");
        std::stringstream ss(s);
        for (std::string one; std::getline(ss, one, ',');) {
            if (trim(one).empty()) bad("an empty preset name in '" + s + "' (two commas, or one at an end)");
            Preset p = parse_preset(one);
            if (!seen.insert(p.name).second) bad("preset '" + p.name + "' is given twice");
            out.push_back(std::move(p));
        }
    }
    return out;
}

void check_preset_face_size(const Preset& p, int face_size) {
    if (p.container == Container::Source || preset_level_count(p, face_size) >= 2) return;
    int least = 2;
    while (preset_level_count(p, least) < 2) least *= 2;
    bad("preset '" + p.name + "' needs a face size of " + std::to_string(least) + " or more, not " +
        std::to_string(face_size) + ": its chain stops at " + std::to_string(p.smallest) +
        " px, so it would hold the mirror level alone (every material a mirror, no r = 1 level)");
}

int preset_level_count(const Preset& p, int n0) {
    int m = 0;
    while (m < 30 && std::max(1, n0 >> m) >= p.smallest && (m == 0 || (n0 >> (m - 1)) > 1)) ++m;
    return std::max(1, m);
}

double roughness_linear(int m, int top) { return top <= 0 ? 0.0 : double(m) / top; }

double roughness_filament(int m, int top) {
    if (top <= 0) return 0.0;
    return 1.0 - std::sqrt(std::max(0.0, 1.0 - double(m) / top));
}

double roughness_unity(int m) {
    if (m >= 6) return 1.0;
    return (1.7 - std::sqrt(2.89 - 2.8 * m / 6.0)) / 1.4;
}

double roughness_babylon(int m, int n0, double lod_scale) {
    if (m == 0) return 0.0;
    return std::min(1.0, std::sqrt(std::exp2(m / lod_scale) / n0));
}

double lod_linear(double r, int top) { return top * r; }
double lod_filament(double r, int top) { return top * r * (2.0 - r); }
double lod_unity(double r) { return 6.0 * r * (1.7 - 0.7 * r); }
double lod_babylon(double r, int n0, double lod_scale) { return lod_scale * std::log2(n0 * r * r); }

double preset_roughness(const Preset& p, int m, int levels, int n0) {
    const int top = levels - 1;
    switch (p.curve) {
        case RoughnessCurve::Linear: return roughness_linear(m, top);
        case RoughnessCurve::Filament: return roughness_filament(m, top);
        case RoughnessCurve::Unity: return roughness_unity(m);
        case RoughnessCurve::Babylon: return roughness_babylon(m, n0);
        case RoughnessCurve::None: return 0.0;
    }
    return 0.0;
}

std::vector<PresetLevel> preset_chain(const Preset& p, int n0) {
    std::vector<PresetLevel> chain;
    if (p.container == Container::Source) return chain;
    const int levels = preset_level_count(p, n0);
    for (int m = 0; m < levels; ++m) chain.push_back({m, std::max(1, n0 >> m), preset_roughness(p, m, levels, n0)});
    return chain;
}

}  // namespace iblbake
