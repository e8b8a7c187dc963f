// Which specular levels each preset's chain holds, and what the bake must
// integrate beyond SPEC's own outputs so that every preset gets its levels at
// its own roughness: (face size, roughness) pairs shared between presets and
// with SPEC's chain are integrated once. Pure: no I/O.
#pragma once
#include <vector>

#include "iblbake/bake/bake.h"
#include "iblbake/export/preset.h"

namespace iblbake {

struct PresetLevel {
    int level, face_size;
    double roughness;
};

struct PresetPlan {
    Preset preset;
    int base_face = 0;
    std::vector<PresetLevel> levels;  // level 0 first (empty for the source preset)
};

// Checks each preset against the options (e.g. Babylon needs a power-of-two
// face size) and lays out its chain. Throws std::invalid_argument.
std::vector<PresetPlan> plan_presets(const BakeOptions& bo, const std::vector<Preset>& presets);

// What the bake must add to SPEC's outputs for these plans: the (face size,
// roughness) pairs not among the SPEC levels it bakes, each once, and the
// irradiance, LUTs and source the presets write.
ExtraOutputs extra_outputs(const BakeOptions& bo, const std::vector<PresetPlan>& plans);

// Two roughness values of one level are the same level.
inline bool same_roughness(double a, double b) { return a == b || (a - b < 1e-12 && b - a < 1e-12); }

}  // namespace iblbake
