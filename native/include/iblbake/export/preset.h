// Engine presets as data (docs/export.md): one table row per engine, no
// per-engine code paths. Pure: no I/O.
#pragma once
#include <string>
#include <vector>

#include "iblbake/ibl/brdf_lut.h"

namespace iblbake {

enum class Container { Ktx2, Dds, Ktx1, Env, Source };
enum class PixelFormat { Rgba16f, Rgba32f, E5b9g9r9, R11g11b10f, RgbdPng, Float32 };
enum class Mirror { None, X, Z };
enum class RoughnessCurve { Linear, Filament, Unity, Babylon, None };
// What the engine uses for diffuse light, and so what the preset writes.
enum class DiffuseForm {
    Cube,         // an irradiance cube file (Irr, mirrored like the specular)
    TopLevel,     // the specular chain's top level (r = 1: Pre = Irr)
    ShKtx1,       // Filament's pre-scaled SH in the KTX1 `sh` key
    Polynomial,   // Babylon's spherical polynomial in the .env header
    ShManifest,   // the manifest's SH, handed to the engine's API (Cesium)
    Engine,       // the engine computes its own
};
// SH the manifest gives for the preset.
enum class ShForm { None, Raw, Filament, BabylonPolynomial };

// How the engine takes a directional light (the sun of issue 27, export/sun.h).
struct PresetLight {
    // The engine's world axes against SPEC's engine space (section 2): a
    // left-handed engine's glTF importer mirrors one axis (Babylon z, Unity
    // x). Not the cube's storage mirror: three and Bevy store their cubes
    // mirrored to undo their samplers' flip, and their worlds are SPEC's.
    Mirror world = Mirror::None;
    // intensity = scale x E of the colour's brightest channel (colour x
    // intensity = the illuminance per channel when scale is 1); 1 / pi where
    // the engine's diffuse BRDF leaves out Lambert's 1 / pi.
    double intensity_scale = 1.0;
    std::string units;  // what the intensity is, in the engine's words
    std::string api;    // how to make the light, with its fields named
    bool verified = false;  // rendered against the environment in the engine tests
};

struct Preset {
    std::string name, description;
    Container container;
    PixelFormat format;
    std::vector<PixelFormat> formats;  // every format the container takes here (modifiers)
    bool zstd = false;                 // KTX2 Zstandard supercompression
    Mirror mirror;
    RoughnessCurve curve;
    int smallest = 1;        // smallest face size of the chain (N0 down to this)
    int curve_top = 0;       // Unity: the curve's top level (6); 0: T = M - 1
    DiffuseForm diffuse;
    ShForm sh;
    bool sh_mirrored = false;  // the engine evaluates SH in the mirrored space
    bool lut = false;          // writes brdf_lut.png
    LutModel lut_model = LutModel::HeightCorrelated;
    bool skybox = false;       // writes a level-0-only cube as well (Filament)
    std::string lod_formula, diffuse_note, notes;
    PresetLight light;
};

// The table (docs/export.md), in its documented order.
const std::vector<Preset>& preset_table();

// "name" or "name:modifier[:modifier]" (a pixel format the container takes,
// "zstd" or "nozstd"): the table row with the modifiers applied. Throws
// std::invalid_argument naming what is wrong and what would be right.
Preset parse_preset(const std::string& spec);
// A list of such specs (each may itself be comma-separated); a preset named
// twice is an error.
std::vector<Preset> parse_presets(const std::vector<std::string>& specs);

const char* container_name(Container c);
const char* pixel_format_name(PixelFormat f);
const char* mirror_name(Mirror m);
const char* curve_name(RoughnessCurve c);
const char* diffuse_name(DiffuseForm d);
const char* sh_form_name(ShForm s);

// Levels of the preset's chain for base face n0: n0 down to `smallest` (at
// least one level).
// Throws std::invalid_argument when a face of `face_size` gives the preset's
// chain fewer than two levels (three and filament stop at 16 px: at 16 they
// would hold the mirror level alone).
void check_preset_face_size(const Preset& p, int face_size);
int preset_level_count(const Preset& p, int n0);
// Perceptual roughness of level m of the preset's chain of `levels` levels
// with base face n0 (the inverse of the engine's lod formula).
double preset_roughness(const Preset& p, int m, int levels, int n0);

// One level of a preset's chain.
struct PresetLevel {
    int level, face_size;
    double roughness;
};
// The preset's chain for base face n0, level 0 first: face max(1, n0 >> m)
// at preset_roughness(). Empty for the source preset (it writes no cube).
std::vector<PresetLevel> preset_chain(const Preset& p, int n0);

// The curves themselves (m of T = top level; exact inverses of the engines'
// roughness -> lod mappings, ENGINES.md section 1).
double roughness_linear(int m, int top);
double roughness_filament(int m, int top);
double roughness_unity(int m);  // UNITY_SPECCUBE_LOD_STEPS = 6; 1 for m > 6
double roughness_babylon(int m, int n0, double lod_scale = 0.8);
// The engines' forward mappings (roughness -> lod), for tests and the manifest.
double lod_linear(double r, int top);
double lod_filament(double r, int top);
double lod_unity(double r);
double lod_babylon(double r, int n0, double lod_scale = 0.8);

}  // namespace iblbake
