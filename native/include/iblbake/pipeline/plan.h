// pipeline: the top room of the library, orchestration. It decides what a
// bake makes and writes (this plan), runs it (bake_file.h), writes its files
// and manifest (write.h), gathers what the engine presets export from the
// result (exports.h) and draws the preview sheet (preview.h). Below it, bake/
// computes and export/ encodes; neither knows the other nor this room.
//
// The plan: made once from the caller's options, then handed to every later
// step (bake_file, compute_bake through `bake`, BakeWriter and its manifest,
// the export jobs). None of them plans again from the options. Pure: no I/O.
//
// Each preset's chain is laid out here, and the (face size, roughness) pairs
// the presets share with each other and with SPEC's chain are integrated once
// (`bake.extra`). How the bake then groups nearby roughness values into one
// integration pass is the bake's own scheduling (bake/bake.h): it follows
// from the BakeOptions alone and changes no file.
#pragma once
#include <vector>

#include <nlohmann/json.hpp>

#include "iblbake/bake/bake.h"
#include "iblbake/export/layout.h"
#include "iblbake/export/preset.h"

namespace iblbake {

enum class PngEncoding { Srgb, Rgbm };

struct WriteOptions {
    bool exr = true, png = false;
    bool float32 = false;        // crosses as full float (the LUT always is)
    PngEncoding png_encoding = PngEncoding::Srgb;
    float exposure = 0.0f;       // stops, PNG only
    float rgbm_range = 8.0f;
    bool preview = false;        // also preview.png, the contact sheet of pipeline/preview.h
    // More top-level manifest keys (e.g. what a Blender world was turned
    // into); they may not replace the contract's own keys.
    nlohmann::json manifest_extra = nlohmann::json::object();
    // Engine presets: each writes its files into OUT/<name>/ (docs/export.md).
    std::vector<Preset> presets;
    CubeLayout layout = CubeLayout::HCross;  // how the crosses at OUT/ are laid out
    void validate() const;  // throws std::invalid_argument
};

struct PresetPlan {
    Preset preset;
    int base_face = 0;
    std::vector<PresetLevel> levels;  // level 0 first (empty for the source preset)
};

struct BakePlan {
    // What to integrate and what to skip: the caller's options, with `extra`
    // filled with what the presets need beyond SPEC's outputs.
    BakeOptions bake;
    // What to write: formats, layout, preview, the presets.
    WriteOptions write;
    // Each preset's chain, in the order of write.presets.
    std::vector<PresetPlan> presets;
    // The sun as a light (issue 27, bake.sun = split): the bake takes it out
    // of the environment and the writer adds sun.json, sun.gltf (when one is
    // found), the manifest's `sun` and each preset's light (its sun.json).
    bool sun_light = false;
};

// Validates the bake options and checks each preset against them (e.g.
// Babylon needs a power-of-two face size); throws std::invalid_argument. The
// write options are checked where files are written (BakeWriter): a bake
// kept in memory writes none.
BakePlan make_plan(BakeOptions bo, WriteOptions wo);

// The plan's pieces (pure). Lays out each preset's chain for these options;
// throws std::invalid_argument for a preset the options cannot serve.
std::vector<PresetPlan> plan_presets(const BakeOptions& bo, const std::vector<Preset>& presets);

// What the bake must add to SPEC's outputs for these plans: the (face size,
// roughness) pairs not among the SPEC levels it bakes, each once, and the
// irradiance, LUTs and source the presets write.
ExtraOutputs extra_outputs(const BakeOptions& bo, const std::vector<PresetPlan>& plans);

// Two roughness values of one level are the same level.
inline bool same_roughness(double a, double b) { return a == b || (a - b < 1e-12 && b - a < 1e-12); }

}  // namespace iblbake
