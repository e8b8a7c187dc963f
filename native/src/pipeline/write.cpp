#include "iblbake/pipeline/write.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <atomic>
#include <mutex>
#include <map>
#include <memory>

#include <tbb/task_group.h>

#include "iblbake/bake/lut_cache.h"
#include "iblbake/export/export.h"
#include "iblbake/export/sun.h"
#include "iblbake/image/encode.h"
#include "iblbake/io/hash.h"
#include "iblbake/io/image_io.h"
#include "iblbake/io/output_dir.h"
#include "iblbake/io/text.h"
#include "iblbake/pipeline/exports.h"
#include "iblbake/pipeline/preview.h"
#include "iblbake/util/parallel.h"

#ifndef IBLBAKE_VERSION
#define IBLBAKE_VERSION "dev"
#endif

namespace iblbake {

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr float kHalfMax = 65504.0f;

const char* png_encoding_name(PngEncoding e) { return e == PngEncoding::Srgb ? "srgb8" : "rgbm"; }

// One image of a cube in the chosen layout: its file stem, size and rows.
struct LayoutImage {
    std::string stem;
    int width, height;
    std::function<void(int y0, int rows, float* out)> rows;
};

std::vector<LayoutImage> layout_images(const std::string& stem, const Cubemap& cube, CubeLayout layout,
                                       std::shared_ptr<const BorderedCube>& bordered) {
    const int n = cube.size;
    switch (layout) {
        case CubeLayout::HCross:
            return {{stem, 4 * n, 3 * n, [&cube](int y0, int r, float* o) { hcross_rgba_rows(cube, y0, r, o); }}};
        case CubeLayout::VCross:
            return {{stem, 3 * n, 4 * n, [&cube](int y0, int r, float* o) { vcross_rgba_rows(cube, y0, r, o); }}};
        case CubeLayout::Faces: {
            std::vector<LayoutImage> out;
            for (int f = 0; f < 6; ++f)
                out.push_back({stem + "_" + kFaceSuffixes[f], n, n,
                               [&cube, f](int y0, int r, float* o) { face_rgba_rows(cube, f, y0, r, o); }});
            return out;
        }
        case CubeLayout::LatLong: {
            bordered = std::make_shared<const BorderedCube>(BorderedCube::from_cube(cube));
            const BorderedCube* b = bordered.get();
            const int w = 4 * n, h = 2 * n;
            return {{stem, w, h, [b, w, h](int y0, int r, float* o) { latlong_rgba_rows(*b, w, h, y0, r, o); }}};
        }
    }
    return {};
}

// Called between bands of rows: throws Cancelled when the caller says stop.
using Poll = std::function<void()>;

// Writes one cube in the layout (EXR and/or PNG) and records encodings.
void write_cross(const fs::path& dir, const std::string& stem, const Cubemap& cube, const WriteOptions& wo,
                 json& encodings, const Poll& poll) {
    std::shared_ptr<const BorderedCube> bordered;
    // A lat-long resamples the cube bilinearly: it stays within the cube's range.
    const bool full = wo.float32 || exceeds_half(cube.pixels);
    for (const LayoutImage& img : layout_images(stem, cube, wo.layout, bordered)) {
        if (wo.exr) {
            // Streamed in bands: no whole-image buffer.
            io::write_exr_rows((dir / (img.stem + ".exr")).string(), img.width, img.height, 4,
                               full ? io::ExrPixel::Float : io::ExrPixel::Half, [&](int y0, int rows, float* out) {
                                   poll();
                                   img.rows(y0, rows, out);
                               });
            encodings[img.stem + ".exr"] = full ? "float" : "half";
        }
        if (wo.png) {  // streamed in bands too, each encoded as it goes
            const int w = img.width;
            io::write_png8_rows((dir / (img.stem + ".png")).string(), img.width, img.height, 4,
                                [&](int y0, int rows, float* out) {
                                    poll();
                                    img.rows(y0, rows, out);
                                    const size_t n = size_t(rows) * w * 4;
                                    if (wo.png_encoding == PngEncoding::Srgb) encode_srgb_in_place(out, n, wo.exposure);
                                    else encode_rgbm_in_place(out, n, wo.exposure, wo.rgbm_range);
                                });
            encodings[img.stem + ".png"] = png_encoding_name(wo.png_encoding);
        }
    }
}

// The file a manifest entry names (the +X face's for the faces layout).
std::string primary_file(const std::string& stem, const WriteOptions& wo) {
    return stem + (wo.layout == CubeLayout::Faces ? "_px" : "") + (wo.exr ? ".exr" : ".png");
}

// Every file of a cube entry (faces layout: six).
json all_files(const std::string& stem, const WriteOptions& wo) {
    json files = json::array();
    const std::string ext = wo.exr ? ".exr" : ".png";
    if (wo.layout != CubeLayout::Faces) return json::array({stem + ext});
    for (const char* f : kFaceSuffixes) files.push_back(stem + "_" + f + ext);
    return files;
}

}  // namespace

void write_preview(const std::string& path, const BakeResult& r) {
    const Image sheet = render_preview(r);
    std::vector<float> rgba(size_t(sheet.width) * sheet.height * 4, 1.0f);
    for (size_t k = 0; k < size_t(sheet.width) * sheet.height; ++k)
        for (int c = 0; c < 3; ++c) rgba[4 * k + c] = sheet.pixels[3 * k + c];
    encode_srgb_in_place(rgba.data(), rgba.size(), 0.0f);
    io::write_png8(path, sheet.width, sheet.height, 4, rgba);
}

json make_manifest(const BakeResult& r, const BakePlan& plan, const SourceInfo& src, const json& encodings,
                   double write_seconds) {
    const BakeOptions& bo = plan.bake;
    const WriteOptions& wo = plan.write;
    json m;
    m["contract"] = 1;
    m["generator"] = "iblbake";
    // A file name that is not UTF-8 is stored with its odd bytes as \xNN (JSON holds UTF-8 only).
    m["source"] = {{"path", src.path.empty() ? json(nullptr) : json(io::printable(src.path))},
                   {"width", src.width},
                   {"height", src.height},
                   {"sha256", src.sha256.empty() ? json(nullptr) : json(src.sha256)},
                   {"linearised_from_srgb", src.linearised}};
    m["convention"] = "opengl-y-up";
    m["layout"] = layout_name(wo.layout);
    m["face_order"] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
    if (r.irradiance) {
        m["irradiance"] = {{"file", primary_file("irradiance", wo)},
                           {"files", all_files("irradiance", wo)},
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
                        {"files", all_files("specular_" + std::to_string(r.specular_levels[i]), wo)},
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
    if (wo.preview)
        m["preview"] = {{"file", "preview.png"},
                        {"radiance_scale", preview_scale(r)},
                        {"shows", "irradiance, BRDF LUT, every specular level, metal and dielectric spheres per level "
                                  "lit through the split sum; radiance times radiance_scale (a white diffuse surface at 0.5), "
                                  "Reinhard's curve with white 4, sRGB"}};
    json timings = json::object();
    for (const auto& [stage, s] : r.timings) timings[stage] = s;
    if (write_seconds >= 0.0) timings["write"] = write_seconds;
    m["timings"] = timings;
    m["mean_radiance"] = r.mean_radiance;
    m["warnings"] = r.warnings;
    // The instruction set the hierarchical specular sum ran on (null: none ran).
    m["specular_kernel"] = r.specular_kernel.empty() ? json(nullptr) : json(r.specular_kernel);
    m["files"] = json::object();  // filled by write_bake
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
    if (bo.rotation != 0.0) m["options"]["rotation_degrees"] = bo.rotation;
    // The sun as a light (issue 27): only when asked for, so other bakes' manifests are unchanged.
    if (plan.sun_light) {
        m["options"]["sun"] = sun_mode_name(bo.sun);
        m["sun"] = r.sun ? sun_json(*r.sun) : json(nullptr);
    }
    for (const auto& [key, value] : wo.manifest_extra.items()) {
        if (m.contains(key)) throw std::invalid_argument("manifest_extra may not replace the manifest's '" + key + "'");
        m[key] = value;
    }
    return m;
}

struct BakeWriter::Impl {
    const BakePlan& plan;
    const WriteOptions& wo;  // plan.write
    io::StagingDir staging;
    ProgressFn progress;
    LutCache* lut_cache;
    tbb::task_group tasks;
    std::mutex mutex;                                 // parts and error
    std::vector<std::pair<std::string, json>> parts;  // per file set, merged in name order
    std::map<std::string, std::string> hashes;        // sha256 by path in the staging folder
    std::exception_ptr error;
    std::atomic<bool> aborted{false}, computed{false};
    std::mutex poll_mutex;
    bool stopped = false;
    Poll poll;
    Impl(const fs::path& outdir, const BakePlan& pl, const ProgressFn& p, LutCache* c)
        : plan(pl), wo(pl.write), staging(outdir), progress(p), lut_cache(c) {
        // Between bands of rows: a writer being destroyed stops at once; once
        // the bake is computed, the caller is asked too (while it computes,
        // its own progress calls are the bake's).
        poll = [this] {
            if (aborted.load(std::memory_order_relaxed)) throw Cancelled();
            if (!progress || !computed.load(std::memory_order_relaxed)) return;
            std::lock_guard<std::mutex> lock(poll_mutex);
            if (stopped || !progress("writing", 1.0)) {  // the computing is done
                stopped = true;
                throw Cancelled();
            }
        };
    }

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
                for (const auto& item : e.items()) hash(item.key());
            } catch (...) {
                std::lock_guard<std::mutex> lock(mutex);
                if (!error) error = std::current_exception();
                return;
            }
            std::lock_guard<std::mutex> lock(mutex);
            parts.emplace_back(name, std::move(e));
        });
    }

    // A LUT's file: copied from the cache's copy for the same LUT and
    // encoding when it has one, else written (and kept there).
    // pixels_sha256: the table's pixels' sha256 when known (else hashed here).
    void lut_file(const Image& lut, const char* encoding, const fs::path& path, const std::function<void()>& write,
                  const std::string& pixels_sha256 = "") {
        if (!lut_cache) return write();
        const std::string key =
            pixels_sha256.empty() ? encoded_lut_key(lut, encoding) : encoded_lut_key_of(pixels_sha256, encoding);
        std::string sha;
        if (lut_cache->copy_encoded(key, path, &sha)) {
            // The bytes' sha256, verified by the copy: hash() need not read them again.
            const fs::path rel = path.lexically_relative(staging.path());  // path is staging / rel
            if (!rel.empty() && *rel.begin() != ".." && !sha.empty()) {
                std::lock_guard<std::mutex> lock(mutex);
                hashes[rel.generic_string()] = std::move(sha);
            }
            return;
        }
        write();
        lut_cache->store_encoded(key, path);
    }

    // The sha256 of a file this writer has just finished (rel: its path in
    // the staging folder), taken by the task that wrote it while the bytes
    // are in the page cache, not one file after another at the end.
    void hash(const std::string& rel) {
        {
            std::lock_guard<std::mutex> lock(mutex);
            if (hashes.count(rel)) return;  // known already (a LUT file copied from the cache)
        }
        const fs::path p = staging.path() / rel;
        std::error_code ec;
        if (!fs::is_regular_file(p, ec)) return;
        std::string h = io::sha256_file(p.string());
        std::lock_guard<std::mutex> lock(mutex);
        hashes[rel] = std::move(h);
    }
    // Every file under the folder rel, so.
    void hash_tree(const std::string& rel) {
        const fs::path root = staging.path();
        std::error_code ec;
        for (auto it = fs::recursive_directory_iterator(root / rel, ec); !ec && it != fs::recursive_directory_iterator();
             it.increment(ec))
            if (it->is_regular_file(ec)) hash(fs::relative(it->path(), root).generic_string());
    }
};

BakeWriter::BakeWriter(const fs::path& outdir, const BakePlan& plan, const ProgressFn& progress,
                       LutCache* lut_cache) {
    plan.write.validate();
    impl_ = std::make_unique<Impl>(outdir, plan, progress, lut_cache);
}

BakeWriter::~BakeWriter() {
    // Nothing may still write into the staging folder when it is removed.
    impl_->aborted = true;
    impl_->tasks.cancel();
    impl_->tasks.wait();
}

void BakeWriter::cube(const std::string& stem, const Cubemap& cube) {
    Impl& im = *impl_;
    const fs::path dir = im.staging.path();
    im.run(stem, [&im, dir, stem, &cube](json& e) { write_cross(dir, stem, cube, im.wo, e, im.poll); });
}

bool BakeWriter::takes_cubes() const { return !impl_->wo.preview && impl_->plan.presets.empty(); }

void BakeWriter::take_cube(const std::string& stem, Cubemap&& cube) {
    Impl& im = *impl_;
    const fs::path dir = im.staging.path();
    auto held = std::make_shared<Cubemap>(std::move(cube));
    im.run(stem, [&im, dir, stem, held](json& e) {
        write_cross(dir, stem, *held, im.wo, e, im.poll);
        FloatBuffer().swap(held->pixels);  // written: its memory goes now, not with the task
    });
}

void BakeWriter::lut(const Image& lut, const std::string& pixels_sha256) {
    Impl& im = *impl_;
    const fs::path dir = im.staging.path();
    im.run("brdf_lut", [&im, dir, &lut, pixels_sha256](json& e) {
        im.poll();
        // The same table is written the same way by every bake with these
        // settings: its file comes from the cache when it can.
        auto cached = [&](const fs::path& path, const char* encoding, const std::function<void()>& write) {
            im.lut_file(lut, encoding, path, write, pixels_sha256);
        };
        if (im.wo.exr) {
            const fs::path p = dir / "brdf_lut.exr";
            cached(p, "exr-float-zip1-v1", [&] { io::write_exr(p.string(), lut, io::ExrPixel::Float); });
            e["brdf_lut.exr"] = "float";
        }
        if (im.wo.png) {
            const fs::path p = dir / "brdf_lut.png";
            cached(p, "png-unorm16-v1", [&] {
                std::vector<float> v(lut.pixels.size());
                for (size_t k = 0; k < v.size(); ++k) v[k] = std::clamp(lut.pixels[k], 0.0f, 1.0f);
                io::write_png16(p.string(), lut.width, lut.height, 3, v);
            });
            e["brdf_lut.png"] = "unorm16";
        }
    });
}

void BakeWriter::computed() { impl_->computed = true; }

void BakeWriter::wait() {
    impl_->tasks.wait();
    std::lock_guard<std::mutex> lock(impl_->mutex);
    if (impl_->error) io::rethrow_outside_staging(impl_->error);  // the user's path in the message
}

json BakeWriter::finish(const BakeResult& r, const SourceInfo& src) {
    Impl& im = *impl_;
    const auto start = std::chrono::steady_clock::now();
    computed();
    const fs::path dir = im.staging.path();
    const WriteOptions& wo = im.wo;
    // What needs the whole result: the preview sheet and each engine
    // preset's files into dir/<preset> (export/export.h).
    if (wo.preview)
        im.run("preview.png", [&im, dir, &r](json& e) {
            im.poll();
            write_preview((dir / "preview.png").string(), r);
            e["preview.png"] = "srgb8";
        });
    // The sun as a light: sun.json (found or not) and sun.gltf (when found).
    if (im.plan.sun_light && r.sun)
        im.run("~sun", [&im, dir, &r](json&) {
            im.poll();
            io::write_text((dir / "sun.json").string(), sun_json(*r.sun).dump(2) + "\n");
            if (r.sun->found) io::write_text((dir / "sun.gltf").string(), sun_gltf(*r.sun, "iblbake " IBLBAKE_VERSION));
            im.hash("sun.json");
            if (r.sun->found) im.hash("sun.gltf");
        });
    const std::vector<ExportInput> inputs = export_inputs(r, im.plan);  // the jobs refer to them
    // A preset's LUT file, like SPEC's, copied from the cache when it holds one.
    const LutFileMaker lut_file = [&im](const Image& lut, const char* encoding, const fs::path& path,
                                        const std::function<void()>& write) { im.lut_file(lut, encoding, path, write); };
    const std::vector<ExportJob> exports = export_jobs(inputs, dir, "iblbake " IBLBAKE_VERSION, lut_file);
    std::vector<json> preset_parts(exports.size());
    for (size_t k = 0; k < exports.size(); ++k)
        im.run("~preset", [&im, &exports, &preset_parts, k](json&) {
            im.poll();
            preset_parts[k] = exports[k].run();
            im.hash_tree(exports[k].preset);
        });
    wait();
    std::stable_sort(im.parts.begin(), im.parts.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    json encodings = json::object();
    for (const auto& part : im.parts)
        for (const auto& [file, enc] : part.second.items()) encodings[file] = enc;
    // "write": how long the files kept the bake waiting once it was computed
    // (the SPEC files were written while it ran).
    const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    json manifest = make_manifest(r, im.plan, src, encodings, waited);
    if (!exports.empty()) {
        json presets = json::object();
        for (size_t k = 0; k < exports.size(); ++k) presets[exports[k].preset] = preset_parts[k];
        manifest["presets"] = presets;
    }
    // Every file's size and sha256: a skip check ("unchanged") can tell a
    // damaged or truncated output from the one written here.
    // (Most were hashed by the tasks that wrote them; the rest here, on
    // every core.)
    std::vector<std::pair<std::string, uintmax_t>> listed;
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec)) {
        if (!it->is_regular_file()) continue;
        listed.emplace_back(fs::relative(it->path(), dir).generic_string(), it->file_size());
    }
    if (ec) throw std::runtime_error("cannot list the files written: " + ec.message());
    im.poll();
    std::vector<std::string> sums(listed.size());
    parallel_for(0, int(listed.size()), [&](int k) {
        const auto known = im.hashes.find(listed[k].first);
        sums[k] = known != im.hashes.end() ? known->second : io::sha256_file((dir / listed[k].first).string());
    });
    json files = json::object();
    for (size_t k = 0; k < listed.size(); ++k)
        files[listed[k].first] = {{"bytes", listed[k].second}, {"sha256", sums[k]}};
    manifest["files"] = files;
    {
        std::ofstream f(dir / "manifest.json");
        f << manifest.dump(2) << "\n";
        f.close();
        if (!f) throw std::runtime_error("cannot write manifest.json");
    }
    im.poll();  // the last moment a cancel leaves the earlier bake in place
    im.staging.commit();
    return manifest;
}

json write_bake(const BakeResult& r, const fs::path& outdir, const BakePlan& plan, const SourceInfo& src,
                const ProgressFn& progress, LutCache* lut_cache) {
    BakeWriter w(outdir, plan, progress, lut_cache);
    w.computed();  // the caller's bake is done: every write polls
    if (r.irradiance) w.cube("irradiance", *r.irradiance);
    for (size_t i = 0; i < r.specular.size(); ++i) w.cube("specular_" + std::to_string(r.specular_levels[i]), r.specular[i]);
    if (r.lut) w.lut(*r.lut, r.lut_sha256);
    return w.finish(r, src);
}

}  // namespace iblbake
