// Writing a bake: files and manifest.json of SPEC.md section 4, atomically,
// and each planned preset's files (export/) beside them.
#pragma once
#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "iblbake/bake/bake.h"
#include "iblbake/pipeline/plan.h"

namespace iblbake {

struct SourceInfo {
    std::string path;    // empty for in-memory sources
    int width = 0, height = 0;
    std::string sha256;  // of the file, or of the float pixels for in-memory sources
    bool linearised = false;
};

// The manifest (no I/O). `encodings` maps each written file to its encoding;
// `write_seconds` (when >= 0) is added to the timings as the "write" stage.
// `plan` is the one the bake ran with.
nlohmann::json make_manifest(const BakeResult& r, const BakePlan& plan, const SourceInfo& src,
                             const nlohmann::json& encodings, double write_seconds = -1.0);

// preview.png of a bake (pipeline/preview.h), 8-bit sRGB.
void write_preview(const std::string& path, const BakeResult& r);

// Writes a bake's files as they come (what its plan says to write), each on
// its own task, in parallel with each other and with the rest of the bake
// (an OutputSink for compute_bake), into a staging folder beside `outdir` (io/output_dir.h);
// finish() writes what needs the whole result (preview.png, the engine
// presets' files), lists every file with its size and sha256 in
// manifest.json and swaps the folder in. Destroyed without finish() (a
// failed or cancelled bake), it stops its writes and removes what it wrote.
// `progress` ("writing", 1.0) is polled between bands of rows once the bake
// is computed (in finish()), from any thread, one call at a time; false, or
// an exception from it, cancels the write and leaves `outdir` as it was.
class LutCache;

class BakeWriter : public OutputSink {
public:
    // `plan` is the one the bake runs with; the writer refers to it: keep it
    // alive until the writer is gone. `lut_cache`, when given, also keeps the
    // LUT's encoded files: a bake whose LUT was written before copies the
    // bytes instead of encoding them.
    BakeWriter(const std::filesystem::path& outdir, const BakePlan& plan, const ProgressFn& progress = {},
               LutCache* lut_cache = nullptr);
    ~BakeWriter() override;
    BakeWriter(const BakeWriter&) = delete;
    BakeWriter& operator=(const BakeWriter&) = delete;
    void cube(const std::string& stem, const Cubemap& cube) override;
    // True when the plan's finish() reads no cube's pixels (no preview, no
    // preset): the cubes are then taken and freed once written.
    bool takes_cubes() const override;
    void take_cube(const std::string& stem, Cubemap&& cube) override;
    void lut(const Image& lut, const std::string& pixels_sha256) override;
    void wait() override;
    // The bake is computed: writes poll `progress` from now on (finish() says so itself).
    void computed();
    // Waits for the files, writes the rest and the manifest (its "write"
    // timing: what the writing added to the bake's wall time once the
    // outputs were computed) and commits. `r` is the bake of the writer's
    // plan. Returns the manifest.
    nlohmann::json finish(const BakeResult& r, const SourceInfo& src);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Write every output and manifest.json into `outdir`, atomically (a
// BakeWriter handed everything at once). The manifest's `files` records
// each file's size and sha256; `progress` and `lut_cache` as BakeWriter's. Returns the manifest.
nlohmann::json write_bake(const BakeResult& r, const std::filesystem::path& outdir, const BakePlan& plan,
                          const SourceInfo& src, const ProgressFn& progress = {}, LutCache* lut_cache = nullptr);

}  // namespace iblbake
