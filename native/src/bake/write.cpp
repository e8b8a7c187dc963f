#include "iblbake/bake/write.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <mutex>

#include <tbb/task_group.h>

#include "iblbake/ibl/parallel.h"
#include "iblbake/image/encode.h"
#include "iblbake/io/image_io.h"
#include "iblbake/io/output_dir.h"

namespace iblbake {

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr float kHalfMax = 65504.0f;

const char* png_encoding_name(PngEncoding e) { return e == PngEncoding::Srgb ? "srgb8" : "rgbm"; }

// Writes one cube as a cross (EXR and/or PNG) and records encodings.
void write_cross(const fs::path& dir, const std::string& stem, const Cubemap& cube, const WriteOptions& wo,
                 json& encodings) {
    const int w = 4 * cube.size, h = 3 * cube.size;
    if (wo.exr) {
        // Streamed in bands of the cross: no whole-cross buffer.
        const bool full = wo.float32 || exceeds_half(cube.pixels);
        io::write_exr_rows((dir / (stem + ".exr")).string(), w, h, 4, full ? io::ExrPixel::Float : io::ExrPixel::Half,
                           [&](int y0, int rows, float* out) { hcross_rgba_rows(cube, y0, rows, out); });
        encodings[stem + ".exr"] = full ? "float" : "half";
    }
    if (wo.png) {  // streamed in bands too, each encoded as it goes
        io::write_png8_rows((dir / (stem + ".png")).string(), w, h, 4, [&](int y0, int rows, float* out) {
            hcross_rgba_rows(cube, y0, rows, out);
            const size_t n = size_t(rows) * w * 4;
            if (wo.png_encoding == PngEncoding::Srgb) encode_srgb_in_place(out, n, wo.exposure);
            else encode_rgbm_in_place(out, n, wo.exposure, wo.rgbm_range);
        });
        encodings[stem + ".png"] = png_encoding_name(wo.png_encoding);
    }
}

std::string primary_file(const std::string& stem, const WriteOptions& wo) {
    return stem + (wo.exr ? ".exr" : ".png");
}

}  // namespace

void WriteOptions::validate() const {
    if (!exr && !png) throw std::invalid_argument("no output format: ask for exr, png or both");
    if (!std::isfinite(exposure) || std::fabs(exposure) > 64.0f)
        throw std::invalid_argument("exposure must be a finite number of stops in -64..64");
    if (!manifest_extra.is_object()) throw std::invalid_argument("manifest_extra must be a JSON object");
    if (!std::isfinite(rgbm_range) || !(rgbm_range > 0.0f) || rgbm_range > 1e6f)
        throw std::invalid_argument("rgbm_range must be > 0 and finite");
}

json make_manifest(const BakeResult& r, const BakeOptions& bo, const WriteOptions& wo, const SourceInfo& src,
                   const json& encodings, double write_seconds) {
    json m;
    m["contract"] = 1;
    m["generator"] = "iblbake";
    m["source"] = {{"path", src.path.empty() ? json(nullptr) : json(src.path)},
                   {"width", src.width},
                   {"height", src.height},
                   {"sha256", src.sha256.empty() ? json(nullptr) : json(src.sha256)},
                   {"linearised_from_srgb", src.linearised}};
    m["convention"] = "opengl-y-up";
    m["layout"] = "hcross";
    m["face_order"] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
    if (r.irradiance) {
        m["irradiance"] = {{"file", primary_file("irradiance", wo)},
                           {"face_size", r.irradiance->size},
                           {"divided_by_pi", true},
                           {"method", r.irradiance->size > bo.irradiance_exact_face
                                          ? "exact cosine convolution at face " + std::to_string(bo.irradiance_exact_face) +
                                                ", resampled bilinearly"
                                          : std::string("exact cosine convolution (vector-power cloud + hot texels)")}};
    } else {
        m["irradiance"] = nullptr;
    }
    json spec = json::array();
    for (size_t i = 0; i < r.specular.size(); ++i) {
        spec.push_back({{"level", r.specular_levels[i]},
                        {"file", primary_file("specular_" + std::to_string(r.specular_levels[i]), wo)},
                        {"face_size", r.specular[i].size},
                        {"roughness", r.roughness[i]},
                        {"samples_per_texel", r.samples_per_texel[i]},
                        {"method", r.specular_methods[i]}});
    }
    m["specular"] = spec;
    m["specular_roughness_mapping"] = "linear: r_m = m / (M - 1)";
    if (r.lut) {
        m["brdf_lut"] = {{"file", wo.exr ? "brdf_lut.exr" : "brdf_lut.png"},
                         {"size", r.lut->width},
                         {"model", lut_model_name(bo.lut_model)},
                         {"from_cache", r.lut_from_cache},
                         {"channels", {{"r", "A (scale of F0)"}, {"g", "B (bias)"}, {"b", "0"}}},
                         {"axes", {{"x", "NdotV = (i + 0.5) / N"}, {"y", "roughness = (j + 0.5) / N, j from the top"}}}};
    } else {
        m["brdf_lut"] = nullptr;
    }
    json sh = json::array();
    for (const auto& ch : r.sh9) sh.push_back(json(std::vector<double>(ch.begin(), ch.end())));
    m["sh9"] = sh;
    m["bad_input"] = {{"nan", r.bad_input.nan},
                      {"inf", r.bad_input.inf},
                      {"negative", r.bad_input.negative},
                      {"pixels", r.bad_input.pixels}};
    json skipped = json::array();
    for (const Skip& s : r.skipped) skipped.push_back({{"what", s.what}, {"why", s.why}});
    m["skipped"] = skipped;
    m["encodings"] = encodings;
    if (wo.png) {
        m["png"] = {{"encoding", png_encoding_name(wo.png_encoding)}, {"exposure_stops", wo.exposure}};
        if (wo.png_encoding == PngEncoding::Rgbm)
            m["png"]["rgbm"] = {{"range", wo.rgbm_range},
                                {"decode", "linear = rgb * a * range * 2^-exposure"},
                                {"alpha", "holds M on faces (not 1); 0 on unused cross cells"}};
    }
    json timings = json::object();
    for (const auto& [stage, s] : r.timings) timings[stage] = s;
    if (write_seconds >= 0.0) timings["write"] = write_seconds;
    m["timings"] = timings;
    m["mean_radiance"] = r.mean_radiance;
    m["integration_grid"] = {{"width", r.integration_width},
                             {"height", r.integration_height},
                             {"note", "the grid the hot split and, with specular_method fis, the rest cube read; "
                                      "sources under 512 across are resampled from the bilinear L (SPEC 1) onto it "
                                      "for fis only (the hierarchical bins integrate L exactly)"}};
    m["hot_texels"] = {{"count", r.hot_texels},
                       {"threshold", r.hot_threshold},
                       {"power_fraction", r.hot_power_fraction}};
    m["options"] = {{"face_size", bo.face_size},
                    {"irradiance_size", bo.irradiance_size},
                    {"mip_count", bo.resolved_mip_count()},
                    {"lut_size", bo.lut_size},
                    {"lut_model", lut_model_name(bo.lut_model)},
                    {"specular_rings", bo.specular_quality.rings},
                    {"specular_max_phi", bo.specular_quality.max_phi},
                    {"specular_lod_bias", bo.specular_quality.lod_bias},
                    {bo.specular_method == SpecularMethod::Fis ? "specular_base_face" : "specular_finest_bins",
                     r.specular_base_face},
                    {"irradiance_bins", bo.irradiance_bins},
                    {"specular_method", specular_method_name(bo.specular_method)},
                    {"specular_eps", bo.hierarchical.eps},
                    {"lut_phi_points", bo.lut_quality.phi_points},
                    {"lut_u_points", bo.lut_quality.u_points},
                    {"lut_row_nodes", bo.lut_quality.row_nodes},
                    {"hot_threshold", bo.hot_threshold},
                    {"max_hot", bo.max_hot},
                    {"first_level", bo.first_level},
                    {"last_level", bo.resolved_last_level()}};
    for (const auto& [key, value] : wo.manifest_extra.items()) {
        if (m.contains(key)) throw std::invalid_argument("manifest_extra may not replace the manifest's '" + key + "'");
        m[key] = value;
    }
    return m;
}

struct BakeWriter::Impl {
    WriteOptions wo;
    io::StagingDir staging;
    tbb::task_group tasks;
    std::mutex mutex;
    std::vector<std::pair<std::string, json>> parts;  // per file set, merged in name order
    std::exception_ptr error;
    Impl(const fs::path& outdir, const WriteOptions& w) : wo(w), staging(outdir) {}

    // Runs job on its own task; records its encodings or its failure.
    void run(const std::string& name, std::function<void(json&)> job) {
        tasks.run([this, name, job = std::move(job)] {
            {
                std::lock_guard<std::mutex> lock(mutex);
                if (error) return;
            }
            json e = json::object();
            try {
                job(e);
            } catch (...) {
                std::lock_guard<std::mutex> lock(mutex);
                if (!error) error = std::current_exception();
                return;
            }
            std::lock_guard<std::mutex> lock(mutex);
            parts.emplace_back(name, std::move(e));
        });
    }
};

BakeWriter::BakeWriter(const fs::path& outdir, const WriteOptions& wo) {
    wo.validate();
    impl_ = std::make_unique<Impl>(outdir, wo);
}

BakeWriter::~BakeWriter() {
    // Nothing may still write into the staging folder when it is removed.
    impl_->tasks.cancel();
    impl_->tasks.wait();
}

void BakeWriter::cube(const std::string& stem, const Cubemap& cube) {
    const fs::path dir = impl_->staging.path();
    const WriteOptions& wo = impl_->wo;
    impl_->run(stem, [dir, stem, &cube, &wo](json& e) { write_cross(dir, stem, cube, wo, e); });
}

void BakeWriter::lut(const Image& lut) {
    const fs::path dir = impl_->staging.path();
    const WriteOptions& wo = impl_->wo;
    impl_->run("brdf_lut", [dir, &lut, &wo](json& e) {
        if (wo.exr) {
            io::write_exr((dir / "brdf_lut.exr").string(), lut, io::ExrPixel::Float);
            e["brdf_lut.exr"] = "float";
        }
        if (wo.png) {
            std::vector<float> v(lut.pixels.size());
            for (size_t k = 0; k < v.size(); ++k) v[k] = std::clamp(lut.pixels[k], 0.0f, 1.0f);
            io::write_png16((dir / "brdf_lut.png").string(), lut.width, lut.height, 3, v);
            e["brdf_lut.png"] = "unorm16";
        }
    });
}

void BakeWriter::wait() {
    impl_->tasks.wait();
    std::lock_guard<std::mutex> lock(impl_->mutex);
    if (impl_->error) std::rethrow_exception(impl_->error);
}

json BakeWriter::finish(const BakeResult& r, const BakeOptions& bo, const SourceInfo& src) {
    const auto start = std::chrono::steady_clock::now();
    wait();
    std::sort(impl_->parts.begin(), impl_->parts.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    json encodings = json::object();
    for (const auto& part : impl_->parts)
        for (const auto& [file, enc] : part.second.items()) encodings[file] = enc;
    const fs::path dir = impl_->staging.path();
    // "write": how long the files kept the bake waiting once it was computed
    // (they were written while it ran).
    const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    json manifest = make_manifest(r, bo, impl_->wo, src, encodings, waited);
    {
        std::ofstream f(dir / "manifest.json");
        f << manifest.dump(2) << "\n";
        if (!f) throw std::runtime_error("cannot write manifest.json");
    }
    impl_->staging.commit();
    return manifest;
}

json write_bake(const BakeResult& r, const fs::path& outdir, const BakeOptions& bo, const WriteOptions& wo,
                const SourceInfo& src) {
    BakeWriter w(outdir, wo);
    if (r.irradiance) w.cube("irradiance", *r.irradiance);
    for (size_t i = 0; i < r.specular.size(); ++i) w.cube("specular_" + std::to_string(r.specular_levels[i]), r.specular[i]);
    if (r.lut) w.lut(*r.lut);
    return w.finish(r, bo, src);
}

}  // namespace iblbake
