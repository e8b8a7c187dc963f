// iblbake CLI: parses arguments, makes the plan and calls bake_file(). No
// integration here.
#include <CLI/CLI.hpp>

#include <unistd.h>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <new>
#include <set>
#include <string>
#include <vector>

#include "batch.h"
#include "iblbake/export/export.h"
#include "iblbake/io/text.h"
#include "iblbake/pipeline/bake_file.h"
#include "iblbake/pipeline/options.h"

namespace {
// The earlier bake's manifest in `dir` (null when there is none): the CLI
// replaces a folder as scripts expect, and says what went.
nlohmann::json earlier_manifest(const std::string& dir) {
    std::ifstream f(std::filesystem::path(dir) / "manifest.json");
    if (!f) return nullptr;
    nlohmann::json m = nlohmann::json::parse(f, nullptr, false);
    return m.is_object() && m.value("generator", "") == "iblbake" && m.contains("files") && m["files"].is_object()
               ? m
               : nlohmann::json(nullptr);
}

// What a bake's manifest says it was made from: Blender's world, else the source file's name.
std::string made_from(const nlohmann::json& m) {
    if (m.contains("blender") && m["blender"].is_object() && m["blender"].value("world", nlohmann::json()).is_string())
        return "world '" + m["blender"]["world"].get<std::string>() + "'";
    const std::string path = m.contains("source") && m["source"].is_object() ? m["source"].value("path", "") : "";
    return std::filesystem::path(path).filename().string();
}

// "the bake of forest.exr; removed specular_5-8.exr, three/ (2 files)": what
// the new bake (manifest `now`) replaced of the earlier one; "" for nothing.
std::string replaced(const nlohmann::json& before, const nlohmann::json& now) {
    std::vector<std::string> parts;
    const std::string was = made_from(before);
    if (was != made_from(now)) parts.push_back("the bake of " + was);
    std::map<std::string, std::set<int>> levels;  // extension -> levels gone
    std::map<std::string, int> folders;           // folder -> files gone
    std::vector<std::string> gone;
    for (const auto& [name, entry] : before["files"].items()) {
        if (now["files"].contains(name)) continue;
        const size_t slash = name.find('/');
        int level = -1;
        char ext[8] = {0};
        if (slash != std::string::npos) ++folders[name.substr(0, slash)];
        else if (std::sscanf(name.c_str(), "specular_%d.%7s", &level, ext) == 2) levels[ext].insert(level);
        else gone.push_back(name);
    }
    for (const auto& [ext, set] : levels) {
        std::string runs;
        for (auto it = set.begin(); it != set.end();) {
            int first = *it, last = first;
            while (++it != set.end() && *it == last + 1) last = *it;
            runs += (runs.empty() ? "" : ",") + std::to_string(first) + (last > first ? "-" + std::to_string(last) : "");
        }
        gone.push_back("specular_" + runs + "." + ext);
    }
    for (const auto& [dir, n] : folders) gone.push_back(dir + "/ (" + std::to_string(n) + (n == 1 ? " file)" : " files)"));
    std::string files;
    for (const std::string& g : gone) files += (files.empty() ? "" : ", ") + g;
    if (!files.empty()) parts.push_back("removed " + files);
    std::string out;
    for (const std::string& p : parts) out += (out.empty() ? "" : "; ") + p;
    return out;
}

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
// A list option's texts: each split at its commas, empty names kept (and
// refused by the table's check); the presets' texts as given (parse_presets
// splits them and refuses empty names itself).
std::vector<std::string> split_lists(const iblbake::OptionSpec& spec, const std::vector<std::string>& texts) {
    if (spec.open_choices) return texts;
    std::vector<std::string> out;
    for (const std::string& t : texts) {
        const iblbake::OptionValue v = iblbake::parse_option_text(spec, t);
        for (const std::string& item : std::get<std::vector<std::string>>(v)) out.push_back(item);
    }
    return out;
}

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
#if defined(__GLIBC__)
    // One malloc arena for the process: each thread that allocated (TBB's,
    // the reader's, the writer's, OpenEXR's) kept freed blocks in an arena
    // of its own, 7 to 8 MB over the heap's peak on a 1K or 2K bake (forest
    // 1K 51.0 -> 43.1 MB, sunset 2K 71.6 -> 64.2 MB; 16K and face 1024 the
    // same) at the same CPU time (bench/alternate.py, 9 to 11 rounds): the
    // bake's allocations are few and large. The CLI's own choice; the
    // Python module leaves its host's malloc alone.
    mallopt(M_ARENA_MAX, 1);
#endif
    CLI::App app{"iblbake: bake image-based lighting (irradiance, GGX specular, BRDF LUT) from a lat-long HDRI"};
    app.set_version_flag("--version", "iblbake 0.1 (contract 1)");
    bool list_presets = false;
    app.add_flag("--list-presets", list_presets, "print the engine presets and exit");
    app.require_subcommand(0, 1);

    std::vector<std::string> sources;  // one file: a single bake; more, a folder or --list: a batch (cli/batch.h)
    std::string source, outdir;
    cli::BatchArgs batch;
    bool quiet = false, no_cache = false;
    std::string cache_dir = FileLutCache::default_dir().string();

    CLI::App* bake = app.add_subcommand("bake", "bake SOURCE into the files of SPEC.md in OUTDIR");
    bake->add_option("source", sources,
                     "lat-long source image (EXR, HDR, PNG, JPEG, ...); several, or folders: a batch, each world "
                     "into OUTDIR/<name>/ (docs/cli.md)");
    bake->add_option("-o,--output", outdir, "output folder; replaced atomically when the bake completes")->required();
    // Every option of the bake, from the one table (pipeline/options.h): the
    // text each was given, set in the table's order after parsing.
    const BakeRequest defaults;
    std::vector<std::pair<const OptionRow<BakeRequest>*, CLI::Option*>> registered;
    std::vector<std::string> texts(option_table().size());
    std::vector<std::vector<std::string>> lists(option_table().size());
    for (size_t k = 0; k < option_table().size(); ++k) {
        const OptionRow<BakeRequest>& row = option_table()[k];
        const OptionSpec& spec = row.spec;
        if (!(spec.surfaces & kCli)) continue;
        std::string help = (spec.method.empty() ? "" : spec.method + ": ") + spec.help;
        if (spec.has_range() && !std::isinf(spec.max))
            help += " [" + option_value_text(double(spec.min)) + ".." + option_value_text(double(spec.max)) + "]";
        if (spec.kind == OptionKind::Choice || spec.kind == OptionKind::List) {
            std::string names;
            for (const OptionChoice& c : spec.choices) names += (names.empty() ? "" : ", ") + c.value;
            help += ": " + names + (spec.kind == OptionKind::List ? " (repeat or comma-separate)" : "");
        }
        static const char* const kTypeName[] = {"INT", "FLOAT", "", "NAME", "NAME,..."};
        CLI::Option* opt;
        if (spec.kind == OptionKind::Bool) {
            opt = bake->add_flag(spec.cli_flag(), spec.cli_negated ? "do not " + spec.help : spec.help);
        } else if (spec.kind == OptionKind::List) {
            // No CLI11 delimiter: it drops empty names ("three,,khronos"), which
            // are refused (each given text is split below, or by parse_presets).
            opt = bake->add_option(spec.cli_flag(), lists[k], help);
        } else {
            opt = bake->add_option(spec.cli_flag(), texts[k], help);
        }
        if (spec.kind != OptionKind::Bool)
            opt->type_name(kTypeName[int(spec.kind)])->default_str(option_value_text(row.get(defaults)));
        registered.emplace_back(&row, opt);
    }
    bake->add_option("--cache-dir", cache_dir, "where BRDF LUTs are cached for reuse")->capture_default_str();
    bake->add_flag("--no-cache", no_cache, "neither read nor write the LUT cache");
    bake->add_flag("-q,--quiet", quiet, "print nothing on success");
    cli::add_batch_args(bake, batch);

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
        std::vector<std::pair<std::string, OptionValue>> given;
        for (const auto& [row, opt] : registered) {
            if (opt->count() == 0) continue;
            const OptionSpec& spec = row->spec;
            const size_t k = size_t(row - option_table().data());
            if (spec.kind == OptionKind::Bool) given.emplace_back(spec.name, !spec.cli_negated);
            else if (spec.kind == OptionKind::List) given.emplace_back(spec.name, split_lists(spec, lists[k]));
            else given.emplace_back(spec.name, parse_option_text(spec, texts[k]));
        }
        BakeRequest request;
        apply_options(request, given, [](const OptionSpec& s) { return s.cli_flag(); });
        if (sources.empty() && batch.lists.empty())
            throw std::invalid_argument("source is required (see iblbake bake --help)");
        if (cli::is_batch(sources, batch)) {
            FileLutCache cache(cache_dir);
            return cli::run_batch(sources, outdir, request, batch, no_cache ? nullptr : &cache, quiet);
        }
        source = sources.front();
        const BakePlan plan = make_plan(request.bake, request.write);

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
        const nlohmann::json before = earlier_manifest(outdir);
        const nlohmann::json m = bake_file(source, outdir, plan, progress, no_cache ? nullptr : &cache);
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
            if (m.contains("sun") && m["sun"].is_object()) {
                const auto& sun = m["sun"];
                if (sun["found"].get<bool>())
                    std::printf("  sun       %s (sun.json, sun.gltf)\n", sun["why"].get<std::string>().c_str());
                else
                    std::printf("  sun       none: %s (sun.json)\n", sun["why"].get<std::string>().c_str());
            }
            if (m.contains("presets"))
                for (const auto& [name, entry] : m["presets"].items()) {
                    std::string files;
                    for (const auto& [role, file] : entry["files"].items())
                        files += (files.empty() ? "" : ", ") + name + "/" + file.get<std::string>();
                    std::printf("  %-9s %s\n", name.c_str(), files.c_str());
                }
            const std::string note = before.is_null() ? "" : replaced(before, m);
            if (!note.empty())
                std::printf("replaced the earlier bake in %s: %s\n", io::printable(outdir).c_str(),
                            io::printable(note).c_str());
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
