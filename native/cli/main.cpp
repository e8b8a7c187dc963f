// iblbake CLI: parses arguments and calls bake_file(). No integration here.
#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "iblbake/bake/bake_file.h"

namespace {
// SIGINT / SIGTERM ask the bake to stop at its next stage: it then throws
// Cancelled, nothing is written and the staging folder is removed.
std::atomic<bool> g_stop{false};
extern "C" void request_stop(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
    using namespace iblbake;
    CLI::App app{"iblbake: bake image-based lighting (irradiance, GGX specular, BRDF LUT) from a lat-long HDRI"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "iblbake 0.1 (contract 1)");

    BakeOptions bo;
    WriteOptions wo;
    std::string source, outdir, model = "karis", encoding = "srgb", method = "hierarchical";
    std::vector<std::string> formats = {"exr"};
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
    bake->add_flag("--float32", wo.float32, "write crosses as full float instead of half");
    bake->add_option("--png-encoding", encoding, "PNG encoding: srgb (8-bit, clamped) or rgbm")
        ->capture_default_str();
    bake->add_option("--exposure", wo.exposure, "PNG exposure in stops")->capture_default_str();
    bake->add_option("--rgbm-range", wo.rgbm_range, "RGBM range")->capture_default_str();
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

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "iblbake: error: " << e.what() << " (see iblbake bake --help)\n";
        return 2;
    }

    try {
        bo.lut_model = lut_model_from_name(model);
        bo.specular_method = specular_method_from_name(method);
        if (bake->count("--samples") && samples < 1) throw std::invalid_argument("--samples must be >= 1");
        if (samples > 0) {
            bo.specular_quality.rings = std::max(1, int(std::lround(std::sqrt(double(samples)) / 2.0)));
            bo.specular_quality.max_phi = std::max(bo.specular_quality.min_phi,
                                                   int(std::lround(2.0 * std::sqrt(double(samples)))));
        }
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
        std::signal(SIGINT, request_stop);
        std::signal(SIGTERM, request_stop);
        const nlohmann::json m = bake_file(source, outdir, bo, wo, [](const std::string&, double) { return !g_stop; },
                                           no_cache ? nullptr : &cache);
        if (!quiet) {
            double total = 0.0;
            for (const auto& [k, v] : m["timings"].items()) total += v.get<double>();
            std::printf("baked %s -> %s in %.3f s (%zu specular levels, bad pixels: %llu)\n", source.c_str(),
                        outdir.c_str(), total, m["specular"].size(),
                        (unsigned long long)m["bad_input"]["pixels"].get<uint64_t>());
        }
        return 0;
    } catch (const Cancelled& e) {
        std::cerr << "iblbake: error: " << e.what() << " (interrupted); nothing was written\n";
        return 130;
    } catch (const std::exception& e) {
        std::cerr << "iblbake: error: " << e.what() << "\n";
        return 1;
    }
}
