// Writing a bake: files and manifest.json of SPEC.md section 4, atomically.
#pragma once
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "iblbake/bake/bake.h"
#include "iblbake/export/preset.h"
#include "iblbake/export/layout.h"

namespace iblbake {

enum class PngEncoding { Srgb, Rgbm };

struct WriteOptions {
    bool exr = true, png = false;
    bool float32 = false;        // crosses as full float (the LUT always is)
    PngEncoding png_encoding = PngEncoding::Srgb;
    float exposure = 0.0f;       // stops, PNG only
    float rgbm_range = 8.0f;
    bool preview = false;        // also preview.png, the contact sheet of image/preview.h
    // More top-level manifest keys (e.g. what a Blender world was turned
    // into); they may not replace the contract's own keys.
    nlohmann::json manifest_extra = nlohmann::json::object();
    // Engine presets: each writes its files into OUT/<name>/ (docs/export.md).
    std::vector<Preset> presets;
    CubeLayout layout = CubeLayout::HCross;  // how the crosses at OUT/ are laid out
    void validate() const;  // throws std::invalid_argument
};

// `bo` with what the presets of `wo` need from the bake (bo.extra; export/plan.h).
BakeOptions with_exports(BakeOptions bo, const WriteOptions& wo);

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

// preview.png of a bake (image/preview.h), 8-bit sRGB.
void write_preview(const std::string& path, const BakeResult& r);

// Write every output and manifest.json into `outdir`, atomically (io/output_dir.h).
// Returns the manifest.
nlohmann::json write_bake(const BakeResult& r, const std::filesystem::path& outdir, const BakeOptions& bo,
                          const WriteOptions& wo, const SourceInfo& src);

}  // namespace iblbake
