// export: engine presets (preset.h), the conventions between SPEC and each
// engine (convert.h), GPU pixel formats (pixel.h), the container encoders
// (container.h) and the cube layouts (layout.h). It takes its own input
// types, never a bake's result: the pipeline (pipeline/write.h) gathers them.
//
// This header is the export stage itself: one preset's outputs (its chain of
// cubes, the irradiance cube, SH9, a LUT, the source) into its files, through
// the container encoders. Composes convert.h (mirrors, SH forms),
// container.h (bytes) and io/ (files).
#pragma once
#include <array>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "iblbake/export/preset.h"
#include "iblbake/ibl/sun.h"
#include "iblbake/image/image.h"
#include "iblbake/math/sh.h"

namespace iblbake {

// One level of a preset's chain: its place and roughness in the preset's
// curve, and the cube integrated at that roughness (SPEC's convention, not
// mirrored).
struct ExportLevel {
    PresetLevel at;
    const Cubemap* cube = nullptr;
};

// Everything one preset's files are made of. The pointers refer to cubes and
// images owned elsewhere; those a preset does not write may be null.
struct ExportInput {
    Preset preset;
    int base_face = 0;                    // N0 of the chain (Babylon's lod formula)
    std::vector<ExportLevel> levels;      // level 0 first; empty for the source preset
    const Cubemap* irradiance = nullptr;  // DiffuseForm::Cube
    const Image* lut = nullptr;           // preset.lut: the LUT of preset.lut_model
    const Image* source = nullptr;        // Container::Source: the cleaned source
    std::array<Sh9, 3> sh9{};             // the radiance's (SPEC section 5, not mirrored)
    const SunLight* sun = nullptr;        // a sun found (issue 27): its light in the preset's convention, sun.json
};

// One preset's export: writes its files into `dir` / preset name and returns
// its manifest entry. Independent of every other preset's (run them in
// parallel). The jobs refer to the inputs: keep them alive until run.
struct ExportJob {
    std::string preset;
    std::function<nlohmann::json()> run;
};
// How a LUT file is made: `write` writes it to `path`; a writer with a
// cache may copy the file it kept for the same LUT and `encoding` instead
// (BakeWriter's LUT cache). Empty: always written.
using LutFileMaker = std::function<void(const Image& lut, const char* encoding, const std::filesystem::path& path,
                                        const std::function<void()>& write)>;
std::vector<ExportJob> export_jobs(const std::vector<ExportInput>& inputs, const std::filesystem::path& dir,
                                   const std::string& writer, const LutFileMaker& lut_file = {});

// 27 floats, coefficient by coefficient (r, g, b of L00, then L1-1, ...).
std::vector<double> sh_coefficients(const std::array<Sh9, 3>& sh);

// The table as JSON (iblbake presets, iblbake_core.presets()).
nlohmann::json presets_json();

}  // namespace iblbake
