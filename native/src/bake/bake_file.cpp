#include "iblbake/bake/bake_file.h"

#include <chrono>

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
    const auto start = std::chrono::steady_clock::now();
    io::LoadedImage loaded = io::read_image(source_path);
    SourceInfo src;
    src.path = source_path;
    src.width = loaded.image.width;
    src.height = loaded.image.height;
    src.sha256 = io::sha256_file(source_path);
    src.linearised = loaded.linearised;
    const double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    BakeOptions o = with_exports(bo, wo);  // the levels and files the presets need
    o.warnings.insert(o.warnings.begin(), loaded.warnings.begin(), loaded.warnings.end());
    // Every SPEC file is written as soon as its output is made, while the bake goes on.
    BakeWriter writer(outdir, wo, progress, lut_cache);
    BakeResult r = compute_bake(std::move(loaded.image), o, progress, lut_cache, &writer);
    r.timings.insert(r.timings.begin(), {"read", read_seconds});  // reading and hashing the file
    return writer.finish(r, o, src);
}

}  // namespace iblbake
