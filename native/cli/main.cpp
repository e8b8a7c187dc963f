// iblbake CLI: parses arguments and calls bake_file(). No integration here.
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>
#include <string>
#include <vector>

#include "iblbake/bake/bake_file.h"
#include "iblbake/export/export.h"
#include "iblbake/io/text.h"

namespace {
// The presets table (docs/export.md), one block per preset.
void print_presets() {
    for (const auto& p : iblbake::presets_json()) {
        std::printf("%-9s %s\n", p["name"].get<std::string>().c_str(), p["description"].get<std::string>().c_str());
        std::string formats;
        for (const auto& f : p["formats"]) formats += (formats.empty() ? "" : ", ") + f.get<std::string>();
        std::printf("          %s %s (takes %s)%s, mirror %s, curve %s\n", p["container"].get<std::string>().c_str(),
                    p["format"].get<std::string>().c_str(), formats.c_str(),
                    p["supercompression"] == "zstd" ? " + zstd" : "", p["mirror"].get<std::string>().c_str(),
                    p["curve"].get<std::string>().c_str());
        if (!p["levels"].is_null()) {
            std::string r;
            char buf[32];
            for (const auto& v : p["roughness_at_256"]) {
                std::snprintf(buf, sizeof buf, "%s%.3f", r.empty() ? "" : " ", v.get<double>());
                r += buf;
            }
            std::printf("          levels %s; roughness at face 256: %s\n", p["levels"].get<std::string>().c_str(),
                        r.c_str());
            std::printf("          %s\n", p["lod_formula"].get<std::string>().c_str());
        }
        std::printf("          diffuse: %s\n", p["diffuse_note"].get<std::string>().c_str());
    }
    std::printf("\nModifiers: NAME:FORMAT (one the preset takes), NAME:zstd / NAME:nozstd (KTX2).\n");
}

// SIGINT / SIGTERM: while the source is read (nothing made yet, nothing to
// clean) the process ends at once; later they ask the bake to stop at its
// next stage or band of rows being written: it then throws Cancelled, the
// staging folder is removed and the earlier bake stays. Either way the exit
// code is 128 + the signal's number. Once the finished bake is renamed into
// place, a signal is too late and the bake stands.
std::atomic<int> g_signal{0};
std::atomic<bool> g_reading{true};
extern "C" void request_stop(int sig) {
    g_signal = sig;
    if (g_reading) {
        static const char msg[] = "iblbake: error: interrupted while reading the source; nothing was written\n";
        ssize_t ignored = ::write(2, msg, sizeof(msg) - 1);
        (void)ignored;
        ::_exit(128 + sig);
    }
}

// One line naming every exported file whose texels were clamped to its
// pixel format's range (the manifest counts them per file); none when none were.
std::vector<std::string> clamp_notes(const nlohmann::json& m) {
    std::string files;
    uint64_t total = 0;
    if (m.contains("presets"))
        for (const auto& [name, entry] : m["presets"].items())
            for (const auto& w : entry.value("written", nlohmann::json::array()))
                if (w.value("clamped_texels", uint64_t(0)) > 0) {
                    const uint64_t n = w["clamped_texels"].get<uint64_t>();
                    total += n;
                    files += (files.empty() ? "" : ", ") + name + "/" + w["file"].get<std::string>() + " (" +
                             std::to_string(n) + ")";
                }
    if (!total) return {};
    return {std::to_string(total) + " texels brighter than their pixel format holds were clamped to its largest "
            "value: " + files + " (the manifest's clamped_texels)"};
}
}  // namespace

int main(int argc, char** argv) {
    using namespace iblbake;
    const auto started = std::chrono::steady_clock::now();
    CLI::App app{"iblbake: bake image-based lighting (irradiance, GGX specular, BRDF LUT) from a lat-long HDRI"};
    app.set_version_flag("--version", "iblbake 0.1 (contract 1)");
    bool list_presets = false;
    app.add_flag("--list-presets", list_presets, "print the engine presets and exit");
    app.require_subcommand(0, 1);

    BakeOptions bo;
    WriteOptions wo;
    std::string source, outdir, model = "karis", encoding = "srgb", method = "hierarchical";
    std::vector<std::string> formats = {"exr"}, presets;
    std::string layout = "hcross";
    int samples = 0;
    bool no_irr = false, no_spec = false, no_lut = false, quiet = false, no_cache = false;
    std::string cache_dir = FileLutCache::default_dir().string();

    CLI::App* bake = app.add_subcommand("bake", "bake SOURCE into the files of SPEC.md in OUTDIR");
    bake->add_option("source", source, "lat-long source image (EXR, HDR, PNG, JPEG)")->required();
    bake->add_option("-o,--output", outdir, "output folder; replaced atomically when the bake completes")->required();
    bake->add_option("--face-size", bo.face_size, "specular mip 0 face size")->capture_default_str();
    bake->add_option("--irradiance-size", bo.irradiance_size, "irradiance face size")->capture_default_str();
    bake->add_option("--mips", bo.mip_count, "specular mip count (0: full chain down to 1x1)")->capture_default_str();
    bake->add_option("--lut-size", bo.lut_size, "BRDF LUT size (N x N)")->capture_default_str();
    bake->add_option("--lut-model", model, "BRDF LUT model: karis, height-correlated, multiscatter")
        ->capture_default_str();
    bake->add_option("--specular-method", method,
                     "hierarchical (deterministic kernel sum over exact bins) or fis (filtered importance sampling)")
        ->capture_default_str();
    bake->add_option("--eps", bo.hierarchical.eps,
                     "hierarchical: bin size against the kernel's length scale; error grows as eps^3")
        ->capture_default_str();
    bake->add_option("--samples", samples,
                     "fis: samples per texel, approximately (sets --rings to sqrt(S)/2 and the azimuthal cap to "
                     "2 sqrt(S); default 576)");
    bake->add_option("--rings", bo.specular_quality.rings, "fis: quadrature rings per texel")->capture_default_str();
    bake->add_option("--lod-bias", bo.specular_quality.lod_bias, "fis: mip bias of filtered lookups")
        ->capture_default_str();
    bake->add_option("--format", formats, "output formats: exr, png (repeat or comma-separate)")
        ->delimiter(',')
        ->capture_default_str();
    bake->add_option("--preset", presets,
                     "engine preset(s), each into OUTDIR/NAME (repeat or comma-separate; `iblbake presets` lists them): "
                     "three, khronos, bevy, filament, babylon, unity, source; NAME:FORMAT picks a pixel format");
    // No CLI11 delimiter: parse_presets splits the commas itself and refuses empty names ("three,,khronos").
    bake->add_option("--layout", layout, "layout of the cubes in OUTDIR: hcross, vcross, faces, latlong")
        ->capture_default_str();
    bake->add_flag("--float32", wo.float32, "write crosses as full float instead of half");
    bake->add_option("--png-encoding", encoding, "PNG encoding: srgb (8-bit, clamped) or rgbm")
        ->capture_default_str();
    bake->add_option("--exposure", wo.exposure, "PNG exposure in stops")->capture_default_str();
    bake->add_option("--rgbm-range", wo.rgbm_range, "RGBM range")->capture_default_str();
    bake->add_flag("--preview", wo.preview,
                   "also write preview.png: irradiance, LUT, every specular level and spheres lit by the bake");
    bake->add_flag("--no-irradiance", no_irr, "skip the irradiance cube");
    bake->add_flag("--no-specular", no_spec, "skip the specular chain");
    bake->add_flag("--no-lut", no_lut, "skip the BRDF LUT");
    bake->add_flag("--strict", bo.strict, "fail on NaN, Inf or negative source values instead of zeroing them");
    bake->add_option("--threads", bo.threads, "worker threads (0: all cores)")->capture_default_str();
    bake->add_option("--hot-threshold", bo.hot_threshold,
                     "texels brighter than this times the mean are integrated exactly")
        ->capture_default_str();
    bake->add_option("--max-hot", bo.max_hot, "at most this many exactly integrated texels")->capture_default_str();
    bake->add_option("--cache-dir", cache_dir, "where BRDF LUTs are cached for reuse")->capture_default_str();
    bake->add_flag("--no-cache", no_cache, "neither read nor write the LUT cache");
    bake->add_flag("-q,--quiet", quiet, "print nothing on success");

    CLI::App* presets_cmd = app.add_subcommand("presets", "print the engine presets (docs/export.md)");

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "iblbake: error: " << io::printable(e.what()) << " (see iblbake bake --help)\n";
        return 1;
    }

    if (list_presets || presets_cmd->parsed()) {
        print_presets();
        return 0;
    }
    if (!bake->parsed()) {
        std::cerr << "iblbake: error: a subcommand is required: bake or presets (see iblbake --help)\n";
        return 1;
    }

    try {
        bo.lut_model = lut_model_from_name(model);
        wo.presets = parse_presets(presets);
        wo.layout = layout_from_name(layout);
        bo.specular_method = specular_method_from_name(method);
        if (bake->count("--samples") && samples < 1) throw std::invalid_argument("--samples must be >= 1");
        if (samples > 0) {
            bo.specular_quality.rings = std::max(1, int(std::lround(std::sqrt(double(samples)) / 2.0)));
            bo.specular_quality.max_phi = std::max(bo.specular_quality.min_phi,
                                                   int(std::lround(2.0 * std::sqrt(double(samples)))));
        }
        // Options of the other specular method are not silently dropped.
        const bool fis = bo.specular_method == SpecularMethod::Fis;
        for (const char* opt : {"--samples", "--rings", "--lod-bias"})
            if (!fis && bake->count(opt))
                bo.warnings.push_back(std::string(opt) + " applies to --specular-method fis only: ignored");
        if (fis && bake->count("--eps")) bo.warnings.push_back("--eps applies to --specular-method hierarchical only: ignored");
        bo.irradiance = !no_irr;
        bo.specular = !no_spec;
        bo.lut = !no_lut;
        wo.exr = wo.png = false;
        for (const std::string& f : formats) {
            if (f == "exr") wo.exr = true;
            else if (f == "png") wo.png = true;
            else throw std::invalid_argument("unknown format '" + f + "' (expected exr or png)");
        }
        if (encoding == "srgb") wo.png_encoding = PngEncoding::Srgb;
        else if (encoding == "rgbm") wo.png_encoding = PngEncoding::Rgbm;
        else throw std::invalid_argument("unknown PNG encoding '" + encoding + "' (expected srgb or rgbm)");

        FileLutCache cache(cache_dir);
        struct sigaction sa {};
        sa.sa_handler = request_stop;
        sigemptyset(&sa.sa_mask);
        sigaction(SIGINT, &sa, nullptr);
        sigaction(SIGTERM, &sa, nullptr);
        const auto progress = [](const std::string& stage, double) {
            // The source is read and scanned; from here on a signal cancels cooperatively.
            if (stage != "reading source") g_reading = false;
            return g_signal == 0;
        };
        const nlohmann::json m = bake_file(source, outdir, bo, wo, progress, no_cache ? nullptr : &cache);
        g_reading = false;
        for (const auto& w : m["warnings"]) std::cerr << "iblbake: warning: " << w.get<std::string>() << "\n";
        for (const std::string& note : clamp_notes(m)) std::cerr << "iblbake: warning: " << note << "\n";
        if (!quiet) {
            const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
            const std::string kernel = m["specular_kernel"].is_string()
                                           ? ", " + m["specular_kernel"].get<std::string>() + " specular kernel"
                                           : "";
            std::printf("baked %s -> %s in %.3f s (reading included; %zu specular levels%s, bad pixels: %llu)\n",
                        io::printable(source).c_str(), io::printable(outdir).c_str(), wall, m["specular"].size(),
                        kernel.c_str(), (unsigned long long)m["bad_input"]["pixels"].get<uint64_t>());
            if (m.contains("presets"))
                for (const auto& [name, entry] : m["presets"].items()) {
                    std::string files;
                    for (const auto& [role, file] : entry["files"].items())
                        files += (files.empty() ? "" : ", ") + name + "/" + file.get<std::string>();
                    std::printf("  %-9s %s\n", name.c_str(), files.c_str());
                }
        }
        return 0;
    } catch (const Cancelled& e) {
        g_reading = false;
        const int sig = g_signal;
        std::cerr << "iblbake: error: " << e.what() << " (" << (sig ? strsignal(sig) : "interrupted")
                  << "); nothing was written, the earlier bake is unchanged\n";
        return 128 + (sig ? sig : SIGINT);
    } catch (const std::bad_alloc&) {
        std::cerr << "iblbake: error: out of memory (try a smaller --face-size or source)\n";
        return 1;
    } catch (const std::exception& e) {
        std::string msg = io::printable(e.what());
        const std::string fs_prefix = "filesystem error: ";
        if (msg.rfind(fs_prefix, 0) == 0) msg = "file system: " + msg.substr(fs_prefix.size());
        std::cerr << "iblbake: error: " << msg << "\n";
        return 1;
    }
}
