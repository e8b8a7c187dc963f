#include "iblbake/pipeline/bake_file.h"

#include <tbb/task_group.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <filesystem>
#include <memory>
#include <system_error>

#include "iblbake/io/hash.h"
#include "iblbake/io/image_io.h"
#include "iblbake/io/output_dir.h"
#include "iblbake/io/row_reader.h"
#include "iblbake/pipeline/write.h"

namespace iblbake {

namespace {

// A file's rows (io::open_rows) as the streamed bake's bands.
class FileRows final : public BandSource {
public:
    explicit FileRows(std::unique_ptr<io::RowReader> reader) : reader_(std::move(reader)) {}
    int width() const override { return reader_->width(); }
    int height() const override { return reader_->height(); }
    int preferred_band() const override { return reader_->preferred_band(); }
    void read(int y0, int rows, float* out) override { reader_->read(y0, rows, out); }
    bool has_halves() const override { return reader_->has_halves(); }
    void read_halves(int y0, int rows, uint16_t* out) override { reader_->read_halves(y0, rows, out); }
    const io::RowReader& reader() const { return *reader_; }

private:
    std::unique_ptr<io::RowReader> reader_;
};

// Runs `work` on a task beside the caller's `main` (or after it, with one
// thread), waits, and rethrows the first failure (main's first).
template <typename Side, typename Main>
void beside(bool one_thread, Side&& work, Main&& main) {
    if (one_thread) {
        main();
        work();
        return;
    }
    tbb::task_group side;
    std::exception_ptr side_error;
    side.run([&] {
        try {
            work();
        } catch (...) {
            side_error = std::current_exception();
        }
    });
    try {
        main();
    } catch (...) {
        side.wait();
        throw;
    }
    side.wait();
    if (side_error) std::rethrow_exception(side_error);
}

// What a streamed bake of `rows` holds: its state, and three bands of float
// RGB (the two the reader and the reductions take turns with, and the
// decoder's own). A 2K DWAB EXR (256-line blocks, bands of 512 rows) would
// hold more than its whole float image (25 MB), so it is read whole.
double stream_bytes(const BakeOptions& o, const BandSource& rows) {
    return stream_state_bytes(o) + 3.0 * 12.0 * rows.width() * std::min(rows.height(), rows.preferred_band());
}

// The plan's options with what the file's reading found odd (the result's first warnings).
BakeOptions with_reader_warnings(const BakeOptions& plan_options, const std::vector<std::string>& warnings) {
    BakeOptions o = plan_options;
    o.warnings.insert(o.warnings.begin(), warnings.begin(), warnings.end());
    return o;
}

}  // namespace

nlohmann::json bake_file(const std::string& source_path, const std::filesystem::path& outdir, const BakePlan& plan,
                         const ProgressFn& progress, LutCache* lut_cache, const io::FileDigest* hashed) {
    // The plan checked the bake options and the presets when it was made.
    plan.write.validate();
    io::check_replaceable(outdir, source_path);  // before any work: nothing to lose later
    const auto start = std::chrono::steady_clock::now();
    SourceInfo src;
    src.path = source_path;
    // Progress never goes back, not even when the overflow guard's fallback
    // starts a streamed bake over from the whole image.
    double reached = 0.0;
    ProgressFn monotone;
    if (progress)
        monotone = [&reached, &progress](const std::string& stage, double f) {
            reached = std::max(reached, f);
            return progress(stage, reached);
        };
    // The source's sha256: the caller's when the file still has the stamp it
    // had when the caller hashed it (checked again once it is decoded),
    // else hashed here, beside the decoding.
    const bool may_reuse = hashed && hashed->stamp && io::stamp_of(source_path) == hashed->stamp;
    auto hash_source = [&] {
        if (!may_reuse) src.sha256 = io::sha256_file(source_path);
    };
    auto settle_hash = [&] {
        if (!may_reuse) return;
        src.sha256 = io::stamp_of(source_path) == hashed->stamp ? hashed->sha256 : io::sha256_file(source_path);
    };
    // The file's sha256 and the writer's staging folder, on a task of their
    // own while the source decodes: the decoder's threads leave gaps (its
    // last blocks), and neither needs the pixels. One thread asked for: in turn.
    std::unique_ptr<BakeWriter> writer;
    auto side_work = [&] {
        hash_source();
        // Every SPEC file is written as soon as its output is made, while the bake goes on.
        writer = std::make_unique<BakeWriter>(outdir, plan, progress, lut_cache);
    };
    std::error_code ec;
    const bool regular = std::filesystem::is_regular_file(source_path, ec);  // the reader refuses the rest
    const bool one_thread = plan.bake.threads == 1 || !regular;
    // A file whose bake needs no whole source is decoded in bands and
    // reduced as it goes (issue 28): its memory does not grow with the file.
    // (EXR, PNG, JPEG, Radiance HDR, PFM: io::open_rows; when its state and
    // bands, stream_bytes(), would not take more memory than the source's floats.)
    std::unique_ptr<FileRows> streamed;
    if (regular && whole_source_reason(plan.bake).empty()) {
        if (auto reader = io::open_rows(source_path))  // refuses what read_image refuses, before any pixel
            streamed = std::make_unique<FileRows>(std::move(reader));
        if (streamed && stream_bytes(plan.bake, *streamed) >= 12.0 * streamed->width() * streamed->height())
            streamed.reset();
    }
    if (streamed) {
        FileRows& rows = *streamed;
        src.width = rows.width();
        src.height = rows.height();
        src.linearised = rows.reader().linearised();
        const BakeOptions o = with_reader_warnings(plan.bake, rows.reader().warnings());
        writer = std::make_unique<BakeWriter>(outdir, plan, progress, lut_cache);
        std::optional<BakeResult> r;
        beside(plan.bake.threads == 1, hash_source,
               [&] { r = compute_bake_stream(rows, o, monotone, lut_cache, writer.get()); });
        if (r) {
            settle_hash();
            return writer->finish(*r, src);
        }
        // Values of 2^64 and more (or all below 2^-64): the overflow guard scales the whole source (nothing written yet).
        streamed.reset();
    }
    io::LoadedImage loaded;
    if (writer) {
        loaded = io::read_image(source_path);
    } else {
        beside(one_thread, side_work, [&] { loaded = io::read_image(source_path); });
    }
    src.width = loaded.image.width;
    src.height = loaded.image.height;
    src.linearised = loaded.linearised;
    const double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const BakeOptions o = with_reader_warnings(plan.bake, loaded.warnings);
    BakeResult r = compute_bake(std::move(loaded.image), o, monotone, lut_cache, writer.get());
    r.timings.insert(r.timings.begin(), {"read", read_seconds});  // reading and hashing the file
    settle_hash();
    return writer->finish(r, src);
}

}  // namespace iblbake
