#include "iblbake/bake/bake.h"

#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>

#include "iblbake/bake/lut_cache.h"
#include "iblbake/ibl/bin_tree.h"
#include "iblbake/ibl/cube_sampling.h"
#include "iblbake/ibl/irradiance.h"
#include "iblbake/ibl/parallel.h"

namespace iblbake {

namespace {

int floor_log2(int n) {
    int l = 0;
    while ((n >> (l + 1)) > 0) ++l;
    return l;
}
int pow2_ceil(double x) {
    int p = 1;
    while (p < x && p < (1 << 20)) p <<= 1;
    return p;
}

// The specular levels a bake integrates: SPEC's (first_level .. last_level)
// and the extra ones engine presets asked for. Levels at r = 0 come first:
// they read the source itself, which an owned source may free afterwards.
struct LevelJob {
    int face_size;
    double roughness;
    int spec_level;  // -1: an extra level
};
std::vector<LevelJob> level_jobs(const BakeOptions& o) {
    std::vector<LevelJob> jobs;
    if (o.specular)
        for (int m = o.first_level; m <= o.resolved_last_level(); ++m)
            jobs.push_back({std::max(1, o.face_size >> m), o.mip_roughness(m), m});
    for (const SpecularLevelRequest& e : o.extra.specular) jobs.push_back({e.face_size, e.roughness, -1});
    std::stable_sort(jobs.begin(), jobs.end(),
                     [](const LevelJob& a, const LevelJob& b) { return (a.roughness > 0.0) < (b.roughness > 0.0); });
    return jobs;
}

// Which levels are integrated together (specular_hierarchical_group): at a
// face size where engine presets asked for extra levels, the levels of that
// face (SPEC's among them), in order of roughness, up to four at a time from
// the smallest and within a factor 1.6 of it (the narrowest lobe's traversal
// serves them all, on finer bins than the others need). A face with no extra
// level keeps SPEC's level to itself, so a bake without presets is unchanged;
// under FIS every level is integrated alone. The groups come in the order of
// their first job.
std::vector<std::vector<size_t>> level_groups(const std::vector<LevelJob>& jobs, bool hierarchical) {
    std::vector<std::vector<size_t>> groups;
    std::vector<char> grouped(jobs.size(), 0);
    auto has_extra = [&](int face) {
        for (const LevelJob& j : jobs)
            if (j.spec_level < 0 && j.roughness > 0.0 && j.face_size == face) return true;
        return false;
    };
    auto candidate = [&](const LevelJob& j) { return hierarchical && j.roughness > 0.0 && has_extra(j.face_size); };
    for (size_t i = 0; i < jobs.size(); ++i) {
        if (grouped[i] || !candidate(jobs[i])) continue;
        // Every candidate of this face, by roughness, split greedily.
        std::vector<size_t> c;
        for (size_t k = 0; k < jobs.size(); ++k)
            if (candidate(jobs[k]) && jobs[k].face_size == jobs[i].face_size) c.push_back(k);
        std::stable_sort(c.begin(), c.end(),
                         [&](size_t x, size_t y) { return jobs[x].roughness < jobs[y].roughness; });
        std::vector<size_t> g;
        std::vector<double> r;
        for (size_t k : c) {
            r.push_back(jobs[k].roughness);
            if (!g.empty() && (g.size() == 4 || jobs[k].roughness > 1.6 * jobs[g[0]].roughness ||
                               !specular_group_safe(r))) {
                groups.push_back(g);
                g.clear();
                r = {jobs[k].roughness};
            }
            g.push_back(k);
        }
        groups.push_back(g);
        for (size_t k : c) grouped[k] = 1;
    }
    for (size_t i = 0; i < jobs.size(); ++i)
        if (!grouped[i]) groups.push_back({i});
    std::sort(groups.begin(), groups.end(), [](const std::vector<size_t>& a, const std::vector<size_t>& b) {
        return *std::min_element(a.begin(), a.end()) < *std::min_element(b.begin(), b.end());
    });
    return groups;
}

// The smallest positive roughness among the levels baked (0 when none is).
double smallest_positive_roughness(const std::vector<LevelJob>& jobs) {
    double r = 0.0;
    for (const LevelJob& j : jobs)
        if (j.roughness > 0.0 && (r == 0.0 || j.roughness < r)) r = j.roughness;
    return r;
}

// Finest specular bins: small enough for every level's lobe (radius <=
// min(level eps, finest_eps) * 2 alpha, about 2.2 / (eps alpha) bins across)
// and horizon rule (radius <= hierarchical_horizon_radius), SPEC's levels and
// the presets' alike, a power of two, at most 4096 across.
int finest_bin_width(const BakeOptions& o) {
    if (o.specular_method != SpecularMethod::Hierarchical) return 2;
    double radius = kPi;
    bool any = false;
    for (const LevelJob& j : level_jobs(o)) {
        const double r = j.roughness;
        if (!(r > 0.0)) continue;
        const double e = std::min(hierarchical_level_eps(o.hierarchical, j.face_size), o.hierarchical.finest_eps);
        radius = std::min({radius, e * 2.0 * r * r, hierarchical_horizon_radius(r, j.face_size, o.hierarchical)});
        any = true;
    }
    if (!any) return 2;
    return std::clamp(pow2_ceil(4.4 / radius), 2, 4096);  // an equator bin of w across: radius 4.44 / w
}

// 0 when the largest value is below 2^64, else the exponent e such that
// dividing by 2^e brings it there.
int overflow_guard_exponent(float max_value) {
    const int e = std::ilogb(std::max(max_value, 1.0f));
    return e >= 64 ? e - 60 : 0;
}

void check(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
}

class StageClock {
public:
    explicit StageClock(BakeResult& r) : r_(r) {}
    void done(const char* stage) {
        const auto now = std::chrono::steady_clock::now();
        r_.timings.emplace_back(stage, std::chrono::duration<double>(now - last_).count());
        last_ = now;
    }

private:
    BakeResult& r_;
    std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

template <typename Fn>
auto in_arena(int threads, Fn&& fn) {
    if (threads <= 0) return fn();
    tbb::task_arena arena(threads);
    return arena.execute(fn);
}

// Waits for a sink's work on the way out of a bake that throws (a bake that
// returns has waited already, and rethrown any failure).
struct SinkGuard {
    OutputSink* sink;
    ~SinkGuard() {
        if (!sink) return;
        try {
            sink->wait();
        } catch (...) {  // the bake's own exception is the one that propagates
        }
    }
};

// The LUT, read from the cache when there (it depends on its settings alone).
void lut_stage(BakeResult& r, const BakeOptions& o, LutCache* lut_cache) {
    const std::string key = lut_cache_key(o.lut_size, o.lut_model, o.lut_quality);
    if (lut_cache) r.lut = lut_cache->load(key);
    if (r.lut && (r.lut->width != o.lut_size || r.lut->height != o.lut_size)) r.lut.reset();
    r.lut_from_cache = bool(r.lut);
    if (!r.lut) {
        r.lut = bake_brdf_lut(o.lut_size, o.lut_model, o.lut_quality);
        if (lut_cache) lut_cache->store(key, *r.lut);
    }
}

// The LUTs of the extra models (engine presets), from the cache when there.
void extra_lut_stage(BakeResult& r, const BakeOptions& o, LutCache* lut_cache) {
    for (LutModel model : o.extra.luts) {
        if (r.lut && model == o.lut_model) continue;  // the SPEC LUT serves
        bool have = false;
        for (const auto& [m, img] : r.extra_luts) have = have || m == model;
        if (have) continue;
        const std::string key = lut_cache_key(o.lut_size, model, o.lut_quality);
        std::optional<Image> lut;
        if (lut_cache) lut = lut_cache->load(key);
        if (lut && (lut->width != o.lut_size || lut->height != o.lut_size)) lut.reset();
        if (!lut) {
            lut = bake_brdf_lut(o.lut_size, model, o.lut_quality);
            if (lut_cache) lut_cache->store(key, *lut);
        }
        r.extra_luts.emplace_back(model, std::move(*lut));
    }
}

// The LUTs (SPEC's, handed to the sink, and the presets'), made beside the
// rest of a bake: they depend on their settings alone, and loading one from
// the cache (reading and checking a 3 MB file) at the end kept one core
// waiting. start() runs them on their own task (once the source is freed,
// so that the bake's peak memory is not raised); join() starts them if
// need be, waits and rethrows their failure; a bake that throws waits for
// them on the way out (nothing may still write into r).
class LutTask {
public:
    LutTask(BakeResult& r, const BakeOptions& o, LutCache* cache, OutputSink* sink)
        : r_(r), o_(o), cache_(cache), sink_(sink) {}
    void start() {
        if (started_ || joined_ || (!o_.lut && o_.extra.luts.empty())) return;
        started_ = true;
        group_.run([&r = r_, &o = o_, cache = cache_, sink = sink_, this] {
            const auto t0 = std::chrono::steady_clock::now();
            try {
                if (o.lut) {
                    lut_stage(r, o, cache);
                    if (sink) sink->lut(*r.lut);
                }
                extra_lut_stage(r, o, cache);
            } catch (...) {
                error_ = std::current_exception();
            }
            seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        });
    }
    LutTask(const LutTask&) = delete;
    LutTask& operator=(const LutTask&) = delete;
    ~LutTask() {
        if (started_) group_.wait();
    }
    // Seconds the LUTs took (on their own task); rethrows their failure.
    double join() {
        start();
        joined_ = true;
        if (!started_) return 0.0;
        group_.wait();
        started_ = false;
        if (error_) std::rethrow_exception(error_);
        return seconds_;
    }

private:
    BakeResult& r_;
    const BakeOptions& o_;
    LutCache* cache_;
    OutputSink* sink_;
    tbb::task_group group_;
    bool started_ = false, joined_ = false;
    std::exception_ptr error_;
    double seconds_ = 0.0;
};

// Multiplies by 2^scale_exp (the overflow guard's way back); a value past
// the float range saturates at the largest float. Returns how many did.
size_t scale_back(FloatBuffer& px, int scale_exp) {
    if (scale_exp == 0) return 0;
    size_t saturated = 0;
    for (float& v : px) {
        v = std::ldexp(v, scale_exp);
        if (std::isinf(v)) {
            v = std::copysign(std::numeric_limits<float>::max(), v);
            ++saturated;
        }
    }
    return saturated;
}

// Waits for a task group on the way out of a scope that throws.
struct GroupWait {
    tbb::task_group& group;
    ~GroupWait() { group.wait(); }
};

// Warnings about the options alone (the caller's first).
void option_warnings(BakeResult& r, const BakeOptions& o) {
    r.warnings = o.warnings;
    const bool exports = o.extra.irradiance || !o.extra.specular.empty() || !o.extra.luts.empty() || o.extra.keep_source;
    if (!o.irradiance && !o.specular && !o.lut && !exports)
        r.warnings.push_back("every output is disabled: a written bake holds manifest.json alone");
}

// The last guard: nothing non-finite leaves a bake. A numpy source is read
// in place without the GIL; one changed while it is read can put NaN in
// the sums, and then the bake fails instead of writing them.
void check_outputs(const BakeResult& r, bool source_in_place) {
    bool ok = (!r.irradiance || all_finite(r.irradiance->pixels)) && (!r.lut || all_finite(r.lut->pixels));
    for (const Cubemap& c : r.specular) ok = ok && all_finite(c.pixels);
    ok = ok && (!r.extra_irradiance || all_finite(r.extra_irradiance->pixels));
    for (const ExtraSpecularLevel& e : r.extra_specular) ok = ok && all_finite(e.cube.pixels);
    for (const auto& [model, lut] : r.extra_luts) ok = ok && all_finite(lut.pixels);
    for (const auto& ch : r.sh9)
        for (const double v : ch) ok = ok && std::isfinite(v);
    if (ok) return;
    throw std::runtime_error(source_in_place
                                 ? "the source array changed while it was being baked (a value that is not finite "
                                   "reached the outputs); nothing was written: do not modify it during bake()"
                                 : "a value that is not finite reached the outputs; nothing was written");
}

// Why an output is off: the caller's reason, else `fallback`.
Skip skip_reason(const BakeOptions& o, const std::string& what, const std::string& fallback) {
    for (const Skip& s : o.skip_reasons)
        if (s.what == what) return {what, s.why};
    return {what, fallback};
}

// The levels outside first_level..last_level, as one `skipped` entry.
void skip_levels(BakeResult& r, const BakeOptions& o) {
    const int mips = o.resolved_mip_count(), last = o.resolved_last_level();
    if (o.first_level == 0 && last == mips - 1) return;
    std::string what = "specular levels";
    if (o.first_level > 0) what += " 0-" + std::to_string(o.first_level - 1);
    if (last < mips - 1)
        what += std::string(o.first_level > 0 ? "," : "") + " " + std::to_string(last + 1) + "-" + std::to_string(mips - 1);
    r.skipped.push_back({what, skip_reason(o, "specular_levels", "outside the requested level range").why});
}

}  // namespace

const char* specular_method_name(SpecularMethod m) {
    return m == SpecularMethod::Fis ? "fis" : "hierarchical";
}

SpecularMethod specular_method_from_name(const std::string& name) {
    if (name == "hierarchical") return SpecularMethod::Hierarchical;
    if (name == "fis") return SpecularMethod::Fis;
    throw std::invalid_argument("unknown specular method '" + name + "' (expected hierarchical or fis)");
}

void BakeOptions::validate() const {
    // 4096: a cube of 6 x 4096^2 RGB floats is 1.2 GB; its cross and files about as much again.
    check(face_size >= 1 && face_size <= 4096, "face_size must be in 1..4096");
    check(irradiance_size >= 1 && irradiance_size <= 4096, "irradiance_size must be in 1..4096");
    check(mip_count >= 0 && mip_count <= 20, "mip_count must be in 0..20 (0 = full chain)");
    check(lut_size >= 1 && lut_size <= 4096, "lut_size must be in 1..4096");
    check(specular_quality.rings >= 1 && specular_quality.rings <= 256, "specular rings must be in 1..256");
    check(specular_quality.min_phi >= 1 && specular_quality.max_phi >= specular_quality.min_phi &&
              specular_quality.max_phi <= 4096,
          "specular phi counts must satisfy 1 <= min_phi <= max_phi <= 4096");
    check(std::isfinite(specular_quality.lod_bias) && std::fabs(specular_quality.lod_bias) <= 16,
          "lod_bias must be finite, in -16..16");
    check(lut_quality.phi_points >= 1 && lut_quality.phi_points <= 256, "LUT phi points must be in 1..256");
    check(lut_quality.u_points >= 1 && lut_quality.u_points <= 256, "LUT u points must be in 1..256");
    check(lut_quality.row_nodes == 0 || (lut_quality.row_nodes >= 4 && lut_quality.row_nodes <= 4096),
          "LUT row nodes must be 0 (every texel) or in 4..4096");
    check(specular_base_face == 0 || (specular_base_face >= 1 && specular_base_face <= 4096 &&
                                      (specular_base_face & (specular_base_face - 1)) == 0),
          "specular_base_face must be 0 (automatic) or a power of two up to 4096");
    check(irradiance_bins >= 2 && irradiance_bins <= 4096 && (irradiance_bins & (irradiance_bins - 1)) == 0,
          "irradiance_bins must be a power of two in 2..4096");
    check(std::isfinite(hierarchical.eps) && hierarchical.eps >= 0.02 && hierarchical.eps <= 2.0,
          "specular eps must be in 0.02..2 (the default 0.5 keeps every texel within about 0.4 %; error grows as eps^3 to eps^4)");
    check(hierarchical.tile >= 0 && hierarchical.tile <= 256, "specular tile must be in 0..256 (0: automatic)");
    check(irradiance_exact_face >= 1 && irradiance_exact_face <= 4096, "irradiance_exact_face must be in 1..4096");
    check(std::isfinite(hot_threshold) && hot_threshold >= 1.0, "hot_threshold must be >= 1");
    check(max_hot >= 0 && max_hot <= 1 << 20, "max_hot must be in 0..1048576");
    check(threads >= 0 && threads <= 1024, "threads must be in 0..1024 (0: all cores)");
    const int mips = resolved_mip_count();
    check(first_level >= 0 && first_level < mips, "first_level must be in 0..mip_count-1");
    check(last_level == -1 || (last_level >= first_level && last_level < mips),
          "last_level must be -1 (the last) or in first_level..mip_count-1");
    for (const SpecularLevelRequest& e : extra.specular)
        check(e.face_size >= 1 && e.face_size <= 4096 && std::isfinite(e.roughness) && e.roughness >= 0.0 &&
                  e.roughness <= 1.0,
              "extra specular levels need a face size in 1..4096 and a roughness in 0..1");
}

int BakeOptions::resolved_last_level() const { return last_level < 0 ? resolved_mip_count() - 1 : last_level; }

int BakeOptions::resolved_mip_count() const { return mip_count > 0 ? mip_count : floor_log2(face_size) + 1; }

double BakeOptions::mip_roughness(int level) const {
    const int m = resolved_mip_count();
    return m == 1 ? 0.0 : double(level) / (m - 1);
}

Image compute_lut(int size, LutModel model, const LutQuality& q, int threads) {
    return in_arena(threads, [&] { return bake_brdf_lut(size, model, q); });
}

namespace {

// The bake of `view`. `owned`, when given, holds the same pixels and may be
// cleaned in place; otherwise a source that needs cleaning is copied first
// and a clean one is read where it lies.
BakeResult bake_source(ImageView view, Image* owned, const BakeOptions& o, const ProgressFn& progress,
                       LutCache* lut_cache, OutputSink* sink) {
    o.validate();
    if (view.width < 1 || view.height < 1) throw std::invalid_argument("source image is empty");
    const bool owned_source = owned != nullptr;
    return in_arena(o.threads, [&] {
        BakeResult r;
        const SinkGuard guard{sink};  // destroyed before r: what the sink reads outlives it
        StageClock clock(r);
        auto report = [&](const std::string& stage, double f) {
            if (progress && !progress(stage, f)) throw Cancelled();
        };
        const int mips = o.resolved_mip_count();
        // Rough share of the work per stage, for the progress bar.
        const double w_irr = o.irradiance || o.extra.irradiance ? 0.15 : 0.0, w_lut = o.lut ? 0.25 : 0.0;
        const double w_spec = o.specular || !o.extra.specular.empty() ? 0.6 : 0.0;
        const double w_total = 0.05 + w_irr + w_spec + w_lut;
        double done = 0.0;
        auto advance = [&](double w) { done += w / w_total; };

        option_warnings(r, o);
        LutTask luts(r, o, lut_cache, sink);
        if (view.width != 2 * view.height)
            r.warnings.push_back("the source is " + std::to_string(view.width) + " x " + std::to_string(view.height) +
                                 ", not 2:1: a lat-long spans 360 x 180 degrees, so its texels are stretched");
        report("reading source", 0.0);
        // The scan, the SH9 projection and the hot split's row sums in one
        // pass over the source; the last two are of the source as it is,
        // used unless cleaning or the overflow guard changes it below.
        SourceSummary summary = summarize_source(view);
        const ImageView scanned = view;
        const SourceScan& scan = summary.scan;
        r.bad_input = scan.bad;
        if (o.strict && r.bad_input.any())
            throw BadInputError("source has " + std::to_string(r.bad_input.pixels) + " bad pixels (" +
                                std::to_string(r.bad_input.nan) + " NaN, " + std::to_string(r.bad_input.inf) +
                                " Inf, " + std::to_string(r.bad_input.negative) + " negative values)");
        // Radiance far beyond what any real HDRI holds (finite floats up to
        // 3.4e38) would overflow the float sums: bring the maximum below 2^64
        // by an exact power of two and scale the outputs back at the end.
        const int scale_exp = overflow_guard_exponent(scan.max_value);
        Image copy;
        std::vector<float> clean_rows;
        std::vector<const float*> row_table;
        if (r.bad_input.any() && scale_exp == 0 && !owned) {
            view = sanitized_view(view, scan, clean_rows, row_table);  // copies the bad rows alone
        } else if (r.bad_input.any() || scale_exp != 0) {
            if (!owned) {
                copy = Image(view.width, view.height);
                std::copy(view.data, view.data + view.value_count(), copy.pixels.begin());
                owned = &copy;
            }
            clean_bad_rows(*owned, scan);
            if (scale_exp != 0)
                for (float& v : owned->pixels) v = std::ldexp(v, -scale_exp);
            view = *owned;
        }
        // Cleaning changed the bad rows alone: their sums again (a few rows,
        // not the whole source's two further passes).
        const bool summary_refreshed = r.bad_input.any() && scale_exp == 0;
        if (summary_refreshed) refresh_summary_rows(summary, view, scan.bad_rows);
        const ImageView source = view;
        clock.done("sanitize");

        // The bins integrate SPEC's bilinear L exactly, whatever the source's
        // size. Filtered importance sampling (`fis`) and the hot split read
        // texel-constant radiance instead: for them a source coarser than 512
        // across is first resampled from L onto a finer grid.
        const int finest_bins = finest_bin_width(o);
        Image resampled;
        if (o.specular_method == SpecularMethod::Fis && (source.width < 512 || source.height < 256))
            resampled = resample_latlong(source, std::max(source.width, 512), std::max(source.height, 256));
        const ImageView integrand = resampled.width > 0 ? ImageView(resampled) : source;
        r.integration_width = integrand.width;
        r.integration_height = integrand.height;
        // The summary describes the integrand when that is the source unchanged
        // or cleaned (its bad rows summarized again above).
        const bool summary_holds =
            scale_exp == 0 && (summary_refreshed ? integrand.data == source.data && integrand.rows == source.rows
                                                 : integrand.data == scanned.data && integrand.rows == scanned.rows);
        r.sh9 = summary_holds ? summary.sh9 : project_sh9(integrand);
        // The mean is the constant band: L_00 = integral of L / (2 sqrt(pi)).
        for (int c = 0; c < 3; ++c) r.mean_radiance[c] = r.sh9[c][0] / (2.0 * std::sqrt(kPi));
        clock.done("sh9");

        const std::vector<LevelJob> jobs = level_jobs(o);
        const double r1 = smallest_positive_roughness(jobs);  // 0: no level needs the integrators
        const bool want_irr = o.irradiance || o.extra.irradiance;
        const bool fis = o.specular_method == SpecularMethod::Fis;

        // Outputs are final once made: scaled back (the overflow guard; a
        // result past the float range, a world of 3.4e38 convolved, saturates
        // at the largest float, counted) and SPEC's handed to the sink, which
        // may start writing them at once.
        size_t saturated = 0;
        auto rescale = [&](FloatBuffer& px) { saturated += scale_back(px, scale_exp); };
        size_t spec_jobs = 0;
        for (const LevelJob& j : jobs) spec_jobs += j.spec_level >= 0;
        r.specular.reserve(spec_jobs);  // the sink holds references into it
        auto finish = [&](const LevelJob& job, Cubemap&& level, size_t samples, const std::string& method) {
            rescale(level.pixels);
            if (job.spec_level >= 0) {
                r.specular.push_back(std::move(level));
                r.specular_levels.push_back(job.spec_level);
                r.roughness.push_back(job.roughness);
                r.samples_per_texel.push_back(samples);
                r.specular_methods.push_back(method);
                if (sink) sink->cube("specular_" + std::to_string(job.spec_level), r.specular.back());
            } else {
                r.extra_specular.push_back({job.face_size, job.roughness, std::move(level), samples, method});
            }
            advance(w_spec / double(jobs.size()));
            report("specular", done);
        };

        // The r = 0 levels (mip 0 by default) first: they read the source
        // itself, and the largest file's writing then overlaps everything
        // that follows.
        bool mirrored = false;
        for (const LevelJob& job : jobs) {
            if (job.roughness != 0.0) continue;
            report("specular", done);
            Cubemap level(job.face_size, Uninitialized{});  // every texel written
            specular_mirror(level, source);
            finish(job, std::move(level), 1, "bilinear source lookup");
            mirrored = true;
        }
        if (mirrored) clock.done("specular_mip0");

        const bool need_split = want_irr || (r1 > 0.0 && fis);
        HotSplit split;
        if (need_split) {
            split = split_hot(integrand, o.hot_threshold, o.max_hot, summary_holds ? &summary.hot : nullptr);
            r.hot_texels = split.hot.size();
            r.hot_threshold = split.threshold;
            r.hot_power_fraction = split.hot_power_fraction;
            clock.done("hot_split");
        }
        advance(0.05);

        auto skip = [&](const char* what) { r.skipped.push_back(skip_reason(o, what, "disabled by option")); };

        // The hierarchical specular's bin tree, built first: its coarser exact
        // bins are the irradiance's too, which then needs no pass of its own.
        const bool need_tree = !fis && r1 > 0.0;
        const bool irr_from_tree = want_irr && need_tree && o.irradiance_bins <= finest_bins / 4;
        BinTree tree;
        std::vector<Bin> irr_bins;
        if (need_tree) {
            report("specular", done);
            r.specular_base_face = finest_bins;
            BinTreeOptions tree_options;
            tree_options.channel_mean = r.mean_radiance.data();
            tree = build_bin_tree(integrand, finest_bins, irr_from_tree ? &irr_bins : nullptr, o.irradiance_bins,
                                  tree_options);
            clock.done("bin_tree");
        }

        // The irradiance convolution runs beside the specular levels (it
        // reads only the bins and the hot points; its own task filled the
        // gaps the levels leave between them); joined below.
        tbb::task_group irr_task;
        const GroupWait irr_wait{irr_task};
        std::exception_ptr irr_error;
        double irr_seconds = 0.0;
        size_t irr_saturated = 0;
        if (want_irr) {
            report("irradiance", done);
            const int bw = o.irradiance_bins, bh = o.irradiance_bins / 2;
            // What reads the source is done here: the levels below may free it.
            if (irr_from_tree) remove_hot(irr_bins, bw, bh, integrand.width, integrand.height, split);
            else irr_bins = reduce_rest_to_bins(integrand, split, bw, bh);
            irr_task.run([&, bw, bh] {
                const auto t0 = std::chrono::steady_clock::now();
                try {
                    const BinGroups groups = group_bins(irr_bins, bw, bh);
                    Cubemap irr(o.irradiance_size);
                    irradiance_convolve(irr, groups, split.hot, o.irradiance_exact_face);
                    irr_saturated = scale_back(irr.pixels, scale_exp);
                    if (o.irradiance) {
                        r.irradiance = std::move(irr);
                        if (sink) sink->cube("irradiance", *r.irradiance);
                    } else {
                        r.extra_irradiance = std::move(irr);
                    }
                } catch (...) {
                    irr_error = std::current_exception();
                }
                irr_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            });
            clock.done("irradiance_start");
        }
        if (!o.irradiance) skip("irradiance");
        auto join_irradiance = [&] {
            irr_task.wait();
            if (irr_error) std::rethrow_exception(irr_error);
            saturated += irr_saturated;
            r.timings.emplace_back("irradiance", irr_seconds);  // its own time, beside the levels
            advance(w_irr);
        };

        if (r1 > 0.0) {
            report("specular", done);
            CubePyramid pyramid;
            if (fis) {
                // The rest cube must resolve the narrowest lobe (about alpha_1
                // radians wide) but need not be finer than the source.
                double rf = mips > 1 ? o.mip_roughness(1) : 1.0;
                for (const SpecularLevelRequest& e : o.extra.specular)
                    if (e.roughness > 0.0) rf = std::min(rf, e.roughness);
                const double a1 = rf * rf;
                int base = o.specular_base_face;
                if (base == 0)
                    base = std::clamp(pow2_ceil(4.0 / a1), 8, std::clamp(pow2_ceil(integrand.width / 4.0), 8, 2048));
                r.specular_base_face = base;
                Cubemap cube(base);
                const int ss = std::clamp(int(std::ceil(integrand.width / (kPi * base))), 1, 4);
                latlong_to_cube(cube, rest_image(integrand, split), ss);  // on the integration grid
                pyramid = build_pyramid(cube);
                clock.done("specular_pyramid");
            } else {
                r.specular_kernel = specular_kernel_isa();
            }
            const std::string method_h = "hierarchical second-order kernel sum over exact bins (eps " +
                                         std::to_string(o.hierarchical.eps).substr(0, 4) + ", " +
                                         r.specular_kernel + " kernel)";
            if (fis || !owned) luts.start();  // no source to free first
            for (const std::vector<size_t>& group : level_groups(jobs, !fis)) {
                const LevelJob& job = jobs[group[0]];
                const int n = job.face_size;
                const double rough = job.roughness;
                if (rough == 0.0) continue;  // made above
                if (!fis && owned) {
                    // Past the r = 0 levels only the tree is read: a source this
                    // bake owns (the CLI's, or a cleaned copy) is freed (or kept
                    // for an export that asked for it) before the rest of the
                    // chain is made and written.
                    if (o.extra.keep_source) r.source = std::move(*owned);
                    FloatBuffer().swap(owned->pixels);
                    owned = nullptr;
                    luts.start();  // its memory in place of the source's
                }
                if (group.size() > 1) {
                    // Levels at nearby roughness in one pass (shared bins and loads).
                    std::vector<Cubemap> levels;
                    for (size_t k = 0; k < group.size(); ++k) levels.emplace_back(n, Uninitialized{});  // every texel written
                    std::vector<SpecularGroupTarget> targets;
                    for (size_t k = 0; k < group.size(); ++k) targets.push_back({&levels[k], jobs[group[k]].roughness});
                    const double bins = specular_hierarchical_group(targets, tree, o.hierarchical);
                    std::string with;
                    for (size_t g : group) with += (with.empty() ? "" : ", ") + std::to_string(jobs[g].roughness);
                    for (size_t k = 0; k < group.size(); ++k)
                        finish(jobs[group[k]], std::move(levels[k]), size_t(std::lround(bins)),
                               method_h + ", one pass for roughness " + with);
                    continue;
                }
                Cubemap level(n, Uninitialized{});  // every texel written
                size_t samples = 0;
                std::string method;
                if (!fis) {
                    samples = size_t(std::lround(specular_hierarchical(level, tree, rough, o.hierarchical)));
                    method = method_h;
                } else {
                    samples = specular_prefilter(level, pyramid, split.hot, rough, o.specular_quality) +
                              split.hot.size();
                    method = "filtered importance sampling + hot texels";
                }
                finish(job, std::move(level), samples, method);
            }
            clock.done("specular");
        }
        if (want_irr) {
            join_irradiance();
            clock.done("irradiance_wait");  // what the bake waited for it after the levels
        }
        if (o.specular) skip_levels(r, o);
        else skip("specular");

        if (o.lut) report("brdf_lut", done);
        const double lut_seconds = luts.join();
        if (o.lut) {
            clock.done("brdf_lut_wait");                     // what the bake waited for it
            r.timings.emplace_back("brdf_lut", lut_seconds);  // its own time, beside the rest
            advance(w_lut);
        } else {
            skip("brdf_lut");
        }
        // A source kept for an export that was not moved out above (not owned,
        // or never freed) is copied from the cleaned view.
        if (o.extra.keep_source && !r.source) {
            r.source = Image(source.width, source.height);
            for (int y = 0; y < source.height; ++y)
                std::copy_n(source.at(0, y), size_t(source.width) * 3, r.source->at(0, y));
        }
        if (scale_exp != 0) {
            if (r.source) rescale(r.source->pixels);
            for (auto& ch : r.sh9)
                for (double& v : ch) v = std::ldexp(v, scale_exp);
            for (double& v : r.mean_radiance) v = std::ldexp(v, scale_exp);
            r.hot_threshold = std::ldexp(r.hot_threshold, scale_exp);
        }
        if (saturated)
            r.warnings.push_back(std::to_string(saturated) +
                                 " output values exceeded the float range and were saturated at 3.4e38");
        check_outputs(r, !owned_source);
        if (sink) sink->wait();
        report("done", 1.0);
        return r;
    });
}

}  // namespace

BakeResult compute_bake(Image source, const BakeOptions& o, const ProgressFn& progress, LutCache* lut_cache,
                        OutputSink* sink) {
    return bake_source(source, &source, o, progress, lut_cache, sink);
}

BakeResult compute_bake_view(ImageView source, const BakeOptions& o, const ProgressFn& progress,
                             LutCache* lut_cache, OutputSink* sink) {
    return bake_source(source, nullptr, o, progress, lut_cache, sink);
}

}  // namespace iblbake

namespace iblbake {

BakeResult compute_constant_bake(const std::array<float, 3>& rgb, const BakeOptions& o, const ProgressFn& progress,
                                 LutCache* lut_cache, OutputSink* sink) {
    o.validate();
    return in_arena(o.threads, [&] {
        BakeResult r;
        const SinkGuard guard{sink};
        StageClock clock(r);
        auto report = [&](const std::string& stage, double f) {
            if (progress && !progress(stage, f)) throw Cancelled();
        };
        option_warnings(r, o);
        report("reading source", 0.0);
        Image one(1, 1);
        std::copy(rgb.begin(), rgb.end(), one.pixels.begin());
        r.bad_input = sanitize(one);
        if (o.strict && r.bad_input.any()) throw BadInputError("the world colour is not a finite, non-negative colour");
        const float* c = one.at(0, 0);
        auto fill = [&](int n) {
            Cubemap cube(n);
            for (size_t k = 0; k < cube.pixels.size(); ++k) cube.pixels[k] = c[k % 3];
            return cube;
        };
        for (int k = 0; k < 3; ++k) {
            r.mean_radiance[k] = c[k];
            r.sh9[k][0] = 2.0 * std::sqrt(kPi) * c[k];  // integral of Y_00 = 1 / (2 sqrt(pi)) over the sphere
        }
        if (o.irradiance) {
            r.irradiance = fill(o.irradiance_size);
            if (sink) sink->cube("irradiance", *r.irradiance);
        } else {
            r.skipped.push_back(skip_reason(o, "irradiance", "disabled by option"));
        }
        if (!o.irradiance && o.extra.irradiance) r.extra_irradiance = fill(o.irradiance_size);
        for (const SpecularLevelRequest& e : o.extra.specular)
            r.extra_specular.push_back({e.face_size, e.roughness, fill(e.face_size), 0, "closed form (constant world)"});
        if (o.extra.keep_source) r.source = one;
        if (o.specular) {
            r.specular.reserve(size_t(o.resolved_last_level() - o.first_level + 1));  // the sink holds references
            for (int m = o.first_level; m <= o.resolved_last_level(); ++m) {
                r.specular.push_back(fill(std::max(1, o.face_size >> m)));
                if (sink) sink->cube("specular_" + std::to_string(m), r.specular.back());
                r.specular_levels.push_back(m);
                r.roughness.push_back(o.mip_roughness(m));
                r.samples_per_texel.push_back(0);
                r.specular_methods.push_back("closed form (constant world)");
            }
            skip_levels(r, o);
        } else {
            r.skipped.push_back(skip_reason(o, "specular", "disabled by option"));
        }
        clock.done("constant");
        if (o.lut) {
            report("brdf_lut", 0.5);
            lut_stage(r, o, lut_cache);
            if (sink) sink->lut(*r.lut);
            clock.done("brdf_lut");
        } else {
            r.skipped.push_back(skip_reason(o, "brdf_lut", "disabled by option"));
        }
        extra_lut_stage(r, o, lut_cache);
        check_outputs(r, false);
        if (sink) sink->wait();
        report("done", 1.0);
        return r;
    });
}

}  // namespace iblbake
