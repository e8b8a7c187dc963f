#include "iblbake/bake/bake_file.h"

#include "iblbake/export/plan.h"
#include "iblbake/io/hash.h"
#include "iblbake/io/image_io.h"
#include "iblbake/io/output_dir.h"

namespace iblbake {

nlohmann::json bake_file(const std::string& source_path, const std::filesystem::path& outdir, const BakeOptions& bo,
                         const WriteOptions& wo, const ProgressFn& progress, LutCache* lut_cache) {
    bo.validate();
    wo.validate();
    plan_presets(bo, wo.presets);  // a preset the options cannot serve fails here, before any work
    io::check_replaceable(outdir, source_path);  // before any work: nothing to lose later
    io::LoadedImage loaded = io::read_image(source_path);
    SourceInfo src;
    src.path = source_path;
    src.width = loaded.image.width;
    src.height = loaded.image.height;
    src.sha256 = io::sha256_file(source_path);
    src.linearised = loaded.linearised;
    const BakeOptions with = with_exports(bo, wo);  // the levels and files the presets need
    const BakeResult r = compute_bake(std::move(loaded.image), with, progress, lut_cache);
    return write_bake(r, outdir, with, wo, src);
}

}  // namespace iblbake
