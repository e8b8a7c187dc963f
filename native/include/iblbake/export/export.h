// The export stage: a bake's levels (BakeResult, with the extra levels the
// plan asked for) into each preset's files, through the container encoders.
// Composes convert.h (mirrors, SH forms), container.h (bytes) and io/ (files).
#pragma once
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "iblbake/bake/bake.h"
#include "iblbake/export/plan.h"

namespace iblbake {

// One preset's export: writes its files into `dir` / preset name and returns
// its manifest entry. Independent of every other preset's (run them in
// parallel). The jobs refer to r, bo and plans: keep them alive until run.
struct ExportJob {
    std::string preset;
    std::function<nlohmann::json()> run;
};
// How a LUT file is made: `write` writes it to `path`; a writer with a
// cache may copy the file it kept for the same LUT and `encoding` instead
// (BakeWriter's LUT cache). Empty: always written.
using LutFileMaker = std::function<void(const Image& lut, const char* encoding, const std::filesystem::path& path,
                                        const std::function<void()>& write)>;
std::vector<ExportJob> export_jobs(const BakeResult& r, const BakeOptions& bo, const std::vector<PresetPlan>& plans,
                                   const std::filesystem::path& dir, const std::string& writer,
                                   const LutFileMaker& lut_file = {});

// The cube of (face size, roughness) in the result: a SPEC level or an extra
// one. Throws std::logic_error when the bake did not make it.
const Cubemap& baked_level(const BakeResult& r, int face_size, double roughness);

// 27 floats, coefficient by coefficient (r, g, b of L00, then L1-1, ...).
std::vector<double> sh_coefficients(const std::array<Sh9, 3>& sh);

// The table as JSON (iblbake presets, iblbake_core.presets()).
nlohmann::json presets_json();

}  // namespace iblbake
