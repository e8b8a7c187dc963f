#include "iblbake/pipeline/exports.h"

#include <stdexcept>
#include <string>

namespace iblbake {

const Cubemap& baked_level(const BakeResult& r, int face_size, double roughness) {
    for (size_t i = 0; i < r.specular.size(); ++i)
        if (r.specular[i].size == face_size && same_roughness(r.roughness[i], roughness)) return r.specular[i];
    for (const ExtraSpecularLevel& e : r.extra_specular)
        if (e.face_size == face_size && same_roughness(e.roughness, roughness)) return e.cube;
    throw std::logic_error("the bake holds no specular level of face " + std::to_string(face_size) + " at roughness " +
                           std::to_string(roughness));
}

namespace {

// The LUT of `model`: SPEC's when it is of that model, else an extra one.
const Image* lut_of(const BakeResult& r, const BakeOptions& bo, LutModel model) {
    const Image* lut = nullptr;
    if (r.lut && bo.lut_model == model) lut = &*r.lut;
    for (const auto& [m, img] : r.extra_luts)
        if (m == model) lut = &img;
    return lut;
}

}  // namespace

std::vector<ExportInput> export_inputs(const BakeResult& r, const BakePlan& plan) {
    // The irradiance cube: SPEC's, else the one made for the presets alone.
    const Cubemap* irradiance = r.irradiance ? &*r.irradiance : r.extra_irradiance ? &*r.extra_irradiance : nullptr;
    std::vector<ExportInput> inputs;
    for (const PresetPlan& pp : plan.presets) {
        ExportInput in;
        in.preset = pp.preset;
        in.base_face = pp.base_face;
        for (const PresetLevel& l : pp.levels) in.levels.push_back({l, &baked_level(r, l.face_size, l.roughness)});
        in.irradiance = irradiance;
        in.lut = lut_of(r, plan.bake, pp.preset.lut_model);
        in.source = r.source ? &*r.source : nullptr;
        in.sh9 = r.sh9;
        in.sun = plan.sun_light && r.sun ? &*r.sun : nullptr;
        inputs.push_back(std::move(in));
    }
    return inputs;
}

}  // namespace iblbake
