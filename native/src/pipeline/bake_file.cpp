#include "iblbake/pipeline/bake_file.h"

#include <tbb/task_group.h>

#include <chrono>
#include <exception>
#include <filesystem>
#include <memory>
#include <system_error>

#include "iblbake/io/hash.h"
#include "iblbake/io/image_io.h"
#include "iblbake/io/output_dir.h"
#include "iblbake/pipeline/write.h"

namespace iblbake {

nlohmann::json bake_file(const std::string& source_path, const std::filesystem::path& outdir, const BakePlan& plan,
                         const ProgressFn& progress, LutCache* lut_cache) {
    // The plan checked the bake options and the presets when it was made.
    plan.write.validate();
    io::check_replaceable(outdir, source_path);  // before any work: nothing to lose later
    const auto start = std::chrono::steady_clock::now();
    SourceInfo src;
    src.path = source_path;
    // The file's sha256 and the writer's staging folder, on a task of their
    // own while the source decodes: the decoder's threads leave gaps (its
    // last blocks), and neither needs the pixels. One thread asked for: in turn.
    std::unique_ptr<BakeWriter> writer;
    auto side_work = [&] {
        src.sha256 = io::sha256_file(source_path);
        // Every SPEC file is written as soon as its output is made, while the bake goes on.
        writer = std::make_unique<BakeWriter>(outdir, plan, progress, lut_cache);
    };
    io::LoadedImage loaded;
    std::error_code ec;
    if (plan.bake.threads == 1 || !std::filesystem::is_regular_file(source_path, ec)) {  // the reader refuses the rest
        loaded = io::read_image(source_path);
        side_work();
    } else {
        tbb::task_group side;
        std::exception_ptr side_error;
        side.run([&] {
            try {
                side_work();
            } catch (...) {
                side_error = std::current_exception();
            }
        });
        try {
            loaded = io::read_image(source_path);
        } catch (...) {
            side.wait();
            throw;
        }
        side.wait();
        if (side_error) std::rethrow_exception(side_error);
    }
    src.width = loaded.image.width;
    src.height = loaded.image.height;
    src.linearised = loaded.linearised;
    const double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    // The plan's options with what the file's reading found odd (the result's first warnings).
    BakeOptions o = plan.bake;
    o.warnings.insert(o.warnings.begin(), loaded.warnings.begin(), loaded.warnings.end());
    BakeResult r = compute_bake(std::move(loaded.image), o, progress, lut_cache, writer.get());
    r.timings.insert(r.timings.begin(), {"read", read_seconds});  // reading and hashing the file
    return writer->finish(r, src);
}

}  // namespace iblbake
