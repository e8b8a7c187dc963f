#include "iblbake/pipeline/plan.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace iblbake {

BakePlan make_plan(BakeOptions bo, WriteOptions wo) {
    bo.validate();
    BakePlan plan;
    plan.presets = plan_presets(bo, wo.presets);
    bo.extra = extra_outputs(bo, plan.presets);
    plan.sun_light = bo.sun == SunMode::Split;
    plan.bake = std::move(bo);
    plan.write = std::move(wo);
    return plan;
}

std::vector<PresetPlan> plan_presets(const BakeOptions& bo, const std::vector<Preset>& presets) {
    std::vector<PresetPlan> plans;
    for (const Preset& p : presets) {
        if (p.container == Container::Env && (bo.face_size & (bo.face_size - 1)))
            throw std::invalid_argument("preset '" + p.name + "' needs a power-of-two face size (Babylon's .env), not " +
                                        std::to_string(bo.face_size));
        check_preset_face_size(p, bo.face_size);
        plans.push_back({p, bo.face_size, preset_chain(p, bo.face_size)});
    }
    return plans;
}

ExtraOutputs extra_outputs(const BakeOptions& bo, const std::vector<PresetPlan>& plans) {
    ExtraOutputs x;
    auto baked = [&](int face, double r) {
        if (bo.specular)
            for (int m = bo.first_level; m <= bo.resolved_last_level(); ++m)
                if (std::max(1, bo.face_size >> m) == face && same_roughness(bo.mip_roughness(m), r)) return true;
        for (const SpecularLevelRequest& e : x.specular)
            if (e.face_size == face && same_roughness(e.roughness, r)) return true;
        return false;
    };
    for (const PresetPlan& plan : plans) {
        const Preset& p = plan.preset;
        for (const PresetLevel& l : plan.levels)
            if (!baked(l.face_size, l.roughness)) x.specular.push_back({l.face_size, l.roughness});
        if (p.diffuse == DiffuseForm::Cube && !bo.irradiance) x.irradiance = true;
        if (p.lut && !(bo.lut && bo.lut_model == p.lut_model)) {
            bool have = false;
            for (LutModel m : x.luts) have = have || m == p.lut_model;
            if (!have) x.luts.push_back(p.lut_model);
        }
        if (p.container == Container::Source) x.keep_source = true;
    }
    return x;
}

}  // namespace iblbake
