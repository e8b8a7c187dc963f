// Writing a bake: files and manifest.json of SPEC.md section 4, atomically.
#pragma once
#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "iblbake/bake/bake.h"

namespace iblbake {

enum class PngEncoding { Srgb, Rgbm };

struct WriteOptions {
    bool exr = true, png = false;
    bool float32 = false;        // crosses as full float (the LUT always is)
    PngEncoding png_encoding = PngEncoding::Srgb;
    float exposure = 0.0f;       // stops, PNG only
    float rgbm_range = 8.0f;
    // More top-level manifest keys (e.g. what a Blender world was turned
    // into); they may not replace the contract's own keys.
    nlohmann::json manifest_extra = nlohmann::json::object();
    void validate() const;  // throws std::invalid_argument
};

struct SourceInfo {
    std::string path;    // empty for in-memory sources
    int width = 0, height = 0;
    std::string sha256;  // of the file, or of the float pixels for in-memory sources
    bool linearised = false;
};

// The manifest (no I/O). `encodings` maps each written file to its encoding;
// `write_seconds` (when >= 0) is added to the timings as the "write" stage.
nlohmann::json make_manifest(const BakeResult& r, const BakeOptions& bo, const WriteOptions& wo,
                             const SourceInfo& src, const nlohmann::json& encodings, double write_seconds = -1.0);

// Writes a bake's files as they come, each on its own task, in parallel
// with each other and with the rest of the bake (an OutputSink for
// compute_bake), into a staging folder beside `outdir` (io/output_dir.h);
// finish() adds manifest.json and swaps the folder in. Destroyed without
// finish() (a failed or cancelled bake), it removes what it wrote.
class BakeWriter : public OutputSink {
public:
    BakeWriter(const std::filesystem::path& outdir, const WriteOptions& wo);
    ~BakeWriter() override;
    BakeWriter(const BakeWriter&) = delete;
    BakeWriter& operator=(const BakeWriter&) = delete;
    void cube(const std::string& stem, const Cubemap& cube) override;
    void lut(const Image& lut) override;
    void wait() override;
    // Waits for the files, writes the manifest (its "write" timing: the wait,
    // the manifest and the swap, what the writing added to the bake's wall
    // time) and commits. Returns the manifest.
    nlohmann::json finish(const BakeResult& r, const BakeOptions& bo, const SourceInfo& src);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Write every output and manifest.json into `outdir`, atomically (a
// BakeWriter handed everything at once). Returns the manifest.
nlohmann::json write_bake(const BakeResult& r, const std::filesystem::path& outdir, const BakeOptions& bo,
                          const WriteOptions& wo, const SourceInfo& src);

}  // namespace iblbake
