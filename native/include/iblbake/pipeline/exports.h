// From a bake to the export room: what each planned preset's files are made
// of, pointing into a BakeResult (export/ never sees one). Pure: no I/O.
#pragma once
#include <vector>

#include "iblbake/bake/bake.h"
#include "iblbake/export/export.h"
#include "iblbake/pipeline/plan.h"

namespace iblbake {

// The cube of (face size, roughness) in the result: a SPEC level or an extra
// one. Throws std::logic_error when the bake did not make it.
const Cubemap& baked_level(const BakeResult& r, int face_size, double roughness);

// One input per planned preset, in the plan's order. The inputs point into
// `r`: keep it alive while they are used. Throws std::logic_error when the
// bake lacks a level the plan asked for.
std::vector<ExportInput> export_inputs(const BakeResult& r, const BakePlan& plan);

}  // namespace iblbake
