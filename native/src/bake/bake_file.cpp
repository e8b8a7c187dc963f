#include "iblbake/bake/bake_file.h"

#include "iblbake/io/hash.h"
#include "iblbake/io/image_io.h"
#include "iblbake/io/output_dir.h"

namespace iblbake {

nlohmann::json bake_file(const std::string& source_path, const std::filesystem::path& outdir, const BakeOptions& bo,
                         const WriteOptions& wo, const ProgressFn& progress, LutCache* lut_cache) {
    bo.validate();
    wo.validate();
    io::check_replaceable(outdir, source_path);  // before any work: nothing to lose later
    io::LoadedImage loaded = io::read_image(source_path);
    SourceInfo src;
    src.path = source_path;
    src.width = loaded.image.width;
    src.height = loaded.image.height;
    src.sha256 = io::sha256_file(source_path);
    src.linearised = loaded.linearised;
    // Every file is written as soon as its output is made, while the bake goes on.
    BakeWriter writer(outdir, wo);
    const BakeResult r = compute_bake(std::move(loaded.image), bo, progress, lut_cache, &writer);
    return writer.finish(r, bo, src);
}

}  // namespace iblbake
