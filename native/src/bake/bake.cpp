#include "iblbake/bake/bake.h"

#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "iblbake/bake/lut_cache.h"
#include "iblbake/bake/options.h"
#include "iblbake/ibl/bin_tree.h"
#include "iblbake/ibl/cube_sampling.h"
#include "iblbake/ibl/irradiance.h"
#include "iblbake/util/parallel.h"

namespace iblbake {

void OutputSink::take_cube(const std::string&, Cubemap&&) {
    throw std::logic_error("OutputSink::take_cube: this sink takes no cubes (takes_cubes() is false)");
}

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

// Whether the tree's kept bins serve the irradiance (its bins at least four
// times coarser than the finest), which then needs no reduction of its own.
bool irradiance_from_tree(const BakeOptions& o, bool need_tree, int finest_bins) {
    return (o.irradiance || o.extra.irradiance) && need_tree && o.irradiance_bins <= finest_bins / 4;
}

// 0 when the largest value lies in [2^-64, 2^64) (or is 0), else the
// exponent e such that dividing by 2^e brings it there: below 2^60 from
// above, to [1, 2) from below. The bins' column sums are float: a source of
// 1e-37 would make products of denormals (2^-64 is 5e-20, far below any
// real HDRI's largest value).
int overflow_guard_exponent(float max_value) {
    if (max_value > 0.0f && std::ilogb(max_value) < -64) return std::ilogb(max_value);
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
// A world whose every texel is 0 lights nothing: baked, but never silently
// (a driver Blender did not run, a Strength of 0, an image of zeros).
void warn_if_black(BakeResult& r) {
    if (r.mean_radiance[0] == 0 && r.mean_radiance[1] == 0 && r.mean_radiance[2] == 0)
        r.warnings.push_back("the world is black (every texel is 0): the bake lights nothing");
}

void lut_stage(BakeResult& r, const BakeOptions& o, LutCache* lut_cache) {
    const std::string key = lut_cache_key(o.lut_size, o.lut_model, o.lut_quality);
    r.lut_sha256.clear();
    if (lut_cache) r.lut = lut_cache->load(key, &r.lut_sha256);
    if (r.lut && (r.lut->width != o.lut_size || r.lut->height != o.lut_size)) r.lut.reset();
    r.lut_from_cache = bool(r.lut);
    if (!r.lut) {
        r.lut_sha256.clear();
        r.lut = bake_brdf_lut(o.lut_size, o.lut_model, o.lut_quality);
        if (lut_cache) lut_cache->store(key, *r.lut, &r.lut_sha256);
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
                    if (sink) sink->lut(*r.lut, r.lut_sha256);
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

std::runtime_error non_finite_output(bool source_in_place) {
    return std::runtime_error(source_in_place
                                  ? "the source array changed while it was being baked (a value that is not finite "
                                    "reached the outputs); nothing was written: do not modify it during bake()"
                                  : "a value that is not finite reached the outputs; nothing was written");
}

// The last guard: nothing non-finite leaves a bake. A numpy source is read
// in place without the GIL; one changed while it is read can put NaN in
// the sums, and then the bake fails instead of writing them. (A cube a sink
// took holds no pixels here: hand_cube() checked it.)
void check_outputs(const BakeResult& r, bool source_in_place) {
    bool ok = (!r.irradiance || all_finite(r.irradiance->pixels)) && (!r.lut || all_finite(r.lut->pixels));
    for (const Cubemap& c : r.specular) ok = ok && all_finite(c.pixels);
    ok = ok && (!r.extra_irradiance || all_finite(r.extra_irradiance->pixels));
    for (const ExtraSpecularLevel& e : r.extra_specular) ok = ok && all_finite(e.cube.pixels);
    for (const auto& [model, lut] : r.extra_luts) ok = ok && all_finite(lut.pixels);
    for (const auto& ch : r.sh9)
        for (const double v : ch) ok = ok && std::isfinite(v);
    if (ok) return;
    throw non_finite_output(source_in_place);
}

// A SPEC cube, final, to the sink (OutputSink): by reference, or (a sink
// that takes cubes) checked and handed over, its size alone left in `kept`.
void hand_cube(OutputSink* sink, const std::string& stem, Cubemap& kept, bool source_in_place) {
    if (!sink) return;
    if (!sink->takes_cubes()) return sink->cube(stem, kept);
    if (!all_finite(kept.pixels)) throw non_finite_output(source_in_place);
    Cubemap taken;
    taken.size = kept.size;
    taken.pixels.swap(kept.pixels);
    sink->take_cube(stem, std::move(taken));
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

const char* sun_mode_name(SunMode m) { return m == SunMode::Split ? "split" : "off"; }

SunMode sun_mode_from_name(const std::string& name) {
    if (name == "off") return SunMode::Off;
    if (name == "split") return SunMode::Split;
    throw std::invalid_argument("unknown sun mode '" + name + "' (expected off or split)");
}

void BakeOptions::validate() const {
    // Each option's own range (bake/options.h: 4096 on a side, since a cube
    // of 6 x 4096^2 RGB floats is 1.2 GB and its cross and files as much again).
    for (const OptionRow<BakeOptions>& row : bake_option_rows()) check_option_range(row, *this);
    // What ties options together.
    check(specular_quality.max_phi >= specular_quality.min_phi,
          "specular phi counts must satisfy 1 <= min_phi <= max_phi <= 4096");
    check(lut_quality.row_nodes == 0 || lut_quality.row_nodes >= 4,
          "LUT row nodes must be 0 (every texel) or in 4..4096");
    check((specular_base_face & (specular_base_face - 1)) == 0,
          "specular_base_face must be 0 (automatic) or a power of two up to 4096");
    check((irradiance_bins & (irradiance_bins - 1)) == 0, "irradiance_bins must be a power of two in 2..4096");
    const int mips = resolved_mip_count();
    check(first_level < mips, "first_level must be in 0..mip_count-1");
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

// A source's bake, stage by stage (bake_source() below runs them in order):
// the options, the result being filled and what each stage leaves for the
// next. Members are destroyed in reverse order: the irradiance task is waited
// for first (it reads the bins and the hot points and writes r), then the
// LUT task (it writes r), then the sink (it reads r's outputs).
struct SourceBake {
    SourceBake(ImageView source_view, Image* owned_pixels, const BakeOptions& options, const ProgressFn& progress_fn,
               LutCache* lut_cache, OutputSink* output_sink)
        : o(options), progress(progress_fn), sink(output_sink), view(source_view), owned(owned_pixels),
          owned_source(owned_pixels != nullptr), guard{output_sink}, clock(r),
          luts(r, options, lut_cache, output_sink) {}

    void report(const std::string& stage, double f) const {
        if (progress && !progress(stage, f)) throw Cancelled();
    }
    void advance(double w) { done += w / w_total; }
    void skip(const char* what) { r.skipped.push_back(skip_reason(o, what, "disabled by option")); }
    // Outputs are final once made: scaled back (the overflow guard; a result
    // past the float range, a world of 3.4e38 convolved, saturates at the
    // largest float, counted) and SPEC's handed to the sink, which may start
    // writing them at once.
    void rescale(FloatBuffer& px) { saturated += scale_back(px, scale_exp); }
    void finish_level(const LevelJob& job, Cubemap&& level, size_t samples, const std::string& method);
    // The caller's pixels read where they lie (a numpy array): a value that
    // is not finite in the outputs may then come from their being changed.
    bool source_in_place() const { return !owned_source && !streamed; }
    // start_irradiance() makes the irradiance's own bins from the source
    // (after the tree: the tree's bins are too coarse for it).
    bool irradiance_reads_source() const { return want_irr && !irr_from_tree && !streamed; }

    const BakeOptions& o;
    const ProgressFn& progress;
    OutputSink* sink;
    ImageView view;           // the source as given; cleaned by sanitize()
    Image* owned;             // the same pixels when this bake may change and free them; null once freed
    const bool owned_source;  // else the caller's pixels are read in place (a numpy array)
    bool streamed = false;    // read in bands (compute_bake_stream): never held whole

    BakeResult r;
    const SinkGuard guard;  // destroyed before r: what the sink reads outlives it
    StageClock clock;
    // Rough share of the work per stage, for the progress bar.
    const double w_irr = o.irradiance || o.extra.irradiance ? 0.15 : 0.0, w_lut = o.lut ? 0.25 : 0.0;
    const double w_spec = o.specular || !o.extra.specular.empty() ? 0.6 : 0.0;
    const double w_total = 0.05 + w_irr + w_spec + w_lut;
    double done = 0.0;
    LutTask luts;
    const bool want_irr = o.irradiance || o.extra.irradiance;
    const bool fis = o.specular_method == SpecularMethod::Fis;

    // scan() and sanitize(): the one pass over the source, and its cleaning.
    SourceSummary summary;
    ImageView scanned;   // the source the summary describes (unless refreshed)
    int scale_exp = 0;   // the overflow guard: the source was divided by 2^scale_exp
    Image copy;          // a cleaned copy of a source not owned
    std::vector<float> clean_rows;
    std::vector<const float*> row_table;
    bool summary_refreshed = false;  // the summary's changed rows (cleaned, sun-free) were summarized again
    ImageView source;                // the cleaned source (turned by orient())
    Image oriented;                  // orient(): the source turned about the up axis
    std::vector<float> sun_rows;     // split_sun(): the changed rows of a source not owned
    std::vector<const float*> sun_row_table;
    // integration_grid(): the grid the integrals run on.
    Image resampled;
    ImageView integrand;
    bool summary_holds = false;  // the summary describes the integrand
    std::array<double, 3> channel_mean{};  // the integrand's texel-constant mean (HotRows): the tree's chroma floor
    std::optional<HotRows> integrand_hot;   // hot_rows(integrand), when the summary does not describe it
    // plan_levels() .. specular_levels().
    int finest_bins = 2;
    std::vector<LevelJob> jobs;
    double r1 = 0.0;  // the smallest positive roughness; 0: no level needs the integrators
    size_t saturated = 0;
    HotSplit split;
    BinTree tree;
    bool irr_from_tree = false;
    std::vector<Bin> irr_bins;
    // The irradiance's own task (start_irradiance(), join_irradiance()).
    tbb::task_group irr_task;
    std::exception_ptr irr_error;
    double irr_seconds = 0.0;
    size_t irr_saturated = 0;
    const GroupWait irr_wait{irr_task};  // last: destroyed first
};

void SourceBake::finish_level(const LevelJob& job, Cubemap&& level, size_t samples, const std::string& method) {
    rescale(level.pixels);
    if (job.spec_level >= 0) {
        r.specular.push_back(std::move(level));
        r.specular_levels.push_back(job.spec_level);
        r.roughness.push_back(job.roughness);
        r.samples_per_texel.push_back(samples);
        r.specular_methods.push_back(method);
        hand_cube(sink, "specular_" + std::to_string(job.spec_level), r.specular.back(), source_in_place());
    } else {
        r.extra_specular.push_back({job.face_size, job.roughness, std::move(level), samples, method});
    }
    advance(w_spec / double(jobs.size()));
    report("specular", done);
}

// Option `strict`: a source with bad texels is refused.
void check_strict(const BakeResult& r, const BakeOptions& o) {
    if (o.strict && r.bad_input.any())
        throw BadInputError("source has " + std::to_string(r.bad_input.pixels) + " bad pixels (" +
                            std::to_string(r.bad_input.nan) + " NaN, " + std::to_string(r.bad_input.inf) + " Inf, " +
                            std::to_string(r.bad_input.negative) + " negative values)");
}

void aspect_warning(BakeResult& r, int w, int h) {
    if (w != 2 * h)
        r.warnings.push_back("the source is " + std::to_string(w) + " x " + std::to_string(h) +
                             ", not 2:1: a lat-long spans 360 x 180 degrees, so its texels are stretched");
}

// The bins whose reduction gives the SH9 (project_sh9_bilinear): the
// tree's finest, else the irradiance's own, else the finest the options
// name. A streamed bake reduces the same ones (BandReducers).
int sh9_bin_width(const SourceBake& b, bool need_tree) {
    return !need_tree && b.want_irr ? b.o.irradiance_bins : b.finest_bins;
}

// The scan and the hot split's row sums in one pass over the source; the
// row sums are of the source as it is, used unless cleaning or the overflow
// guard changes it (sanitize()). The SH9 comes from the bins (bin_tree()).
void scan(SourceBake& b) {
    BakeResult& r = b.r;
    option_warnings(r, b.o);
    aspect_warning(r, b.view.width, b.view.height);
    b.report("reading source", 0.0);
    b.summary = summarize_source(b.view);
    b.scanned = b.view;
    r.bad_input = b.summary.scan.bad;
    check_strict(r, b.o);
    // Radiance far beyond what any real HDRI holds (finite floats up to
    // 3.4e38) would overflow the float sums: bring the maximum below 2^64 by
    // an exact power of two and scale the outputs back at the end (and a
    // whole source below 2^-64 up, out of the denormals).
    b.scale_exp = overflow_guard_exponent(b.summary.scan.max_value);
}

// Bad texels to 0 and the overflow guard's scaling: in place when the bake
// owns the pixels, else in a copy (of the bad rows alone when that is all).
void sanitize(SourceBake& b) {
    const SourceScan& scan = b.summary.scan;
    const bool bad = b.r.bad_input.any();
    if (bad && b.scale_exp == 0 && !b.owned) {
        b.view = sanitized_view(b.view, scan, b.clean_rows, b.row_table);  // copies the bad rows alone
    } else if (bad || b.scale_exp != 0) {
        if (!b.owned) {
            b.copy = Image(b.view.width, b.view.height);
            std::copy(b.view.data, b.view.data + b.view.value_count(), b.copy.pixels.begin());
            b.owned = &b.copy;
        }
        clean_bad_rows(*b.owned, scan);
        if (b.scale_exp != 0)
            for (float& v : b.owned->pixels) v = std::ldexp(v, -b.scale_exp);
        b.view = *b.owned;
    }
    // Cleaning changed the bad rows alone: their sums again (a few rows, not
    // the whole source's two further passes).
    b.summary_refreshed = bad && b.scale_exp == 0;
    if (b.summary_refreshed) refresh_summary_rows(b.summary, b.view, scan.bad_rows);
    b.source = b.view;
    b.clock.done("sanitize");
}

bool same_pixels(const ImageView& a, const ImageView& b) { return a.data == b.data && a.rows == b.rows; }

// The world turned about its up axis (option `rotation`), as Blender's
// Mapping node (Point, Z) turns an Environment Texture: direction d of the
// result shows L(Rz d) of the cleaned source (ibl/source.h's remap_latlong).
// The turned image is the bake's own from here on (an owned source is freed
// at once), and the scan's summary no longer describes it.
void orient(SourceBake& b) {
    if (b.o.rotation == 0.0) return;
    const double a = b.o.rotation * kPi / 180.0, c = std::cos(a), s = std::sin(a);
    b.oriented = remap_latlong(b.source, {c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0}, {0.0, 0.0, 0.0});
    if (b.owned) FloatBuffer().swap(b.owned->pixels);
    b.owned = &b.oriented;
    b.view = b.source = b.oriented;
    b.scanned = ImageView();
    b.summary_refreshed = false;
    b.clock.done("orient");
}


// The sun as a light (option `sun`, ibl/sun.h): found in the cleaned,
// turned source, whose texels it covered are replaced by the sky behind it;
// every stage after this one reads the sun-free source. A source this bake
// owns is changed in place; one it does not gets copies of the changed rows
// (as sanitize() does). The scan's summary, when it described the source,
// is brought up to date for those rows alone.
void split_sun_stage(SourceBake& b) {
    if (b.o.sun != SunMode::Split) return;
    b.report("sun", b.done);
    SunSplit split = split_sun(b.source);
    b.r.sun = split.light;
    if (!split.texels.empty()) {
        const bool described = b.scale_exp == 0 && (b.summary_refreshed || same_pixels(b.source, b.scanned));
        if (b.owned) apply_sun_split(*b.owned, split);
        else b.view = b.source = sun_free_view(b.source, split, b.sun_rows, b.sun_row_table);
        if (described) {
            refresh_summary_rows(b.summary, b.source, split.rows);
            b.summary_refreshed = true;
        }
    }
    b.clock.done("sun");
}

// The SH9 and the mean, the constant band: L_00 = integral of L / (2 sqrt(pi)).
void set_sh9(BakeResult& r, const std::array<Sh9, 3>& sh9) {
    r.sh9 = sh9;
    for (int c = 0; c < 3; ++c) r.mean_radiance[c] = r.sh9[c][0] / (2.0 * std::sqrt(kPi));
}

// The grid the integrals run on (the SH9 of SPEC's L comes with the bins:
// bin_tree()).
void integration_grid(SourceBake& b) {
    BakeResult& r = b.r;
    const ImageView& source = b.source;
    // The bins integrate SPEC's bilinear L exactly, whatever the source's
    // size. Filtered importance sampling (`fis`) and the hot split read
    // texel-constant radiance instead: for them a source coarser than 512
    // across is first resampled from L onto a finer grid.
    if (b.fis && (source.width < 512 || source.height < 256))
        b.resampled = resample_latlong(source, std::max(source.width, 512), std::max(source.height, 256));
    b.integrand = b.resampled.width > 0 ? ImageView(b.resampled) : source;
    r.integration_width = b.integrand.width;
    r.integration_height = b.integrand.height;
    // The summary describes the integrand when that is the source unchanged
    // or cleaned (its bad rows summarized again in sanitize()).
    b.summary_holds = b.scale_exp == 0 && same_pixels(b.integrand, b.summary_refreshed ? source : b.scanned);
    b.clock.done("integration_grid");
}

// The levels to integrate and the finest bins they need.
void plan_levels(SourceBake& b) {
    b.finest_bins = finest_bin_width(b.o);
    b.jobs = level_jobs(b.o);
    b.r1 = smallest_positive_roughness(b.jobs);
    size_t spec_jobs = 0;
    for (const LevelJob& j : b.jobs) spec_jobs += j.spec_level >= 0;
    b.r.specular.reserve(spec_jobs);  // the sink holds references into it
}

// The r = 0 levels (mip 0 by default) first: they read the source itself,
// and the largest file's writing then overlaps everything that follows.
void mirror_levels(SourceBake& b) {
    bool mirrored = false;
    for (const LevelJob& job : b.jobs) {
        if (job.roughness != 0.0) continue;
        b.report("specular", b.done);
        Cubemap level(job.face_size, Uninitialized{});  // every texel written
        specular_mirror(level, b.source);
        b.finish_level(job, std::move(level), 1, "bilinear source lookup");
        mirrored = true;
    }
    if (mirrored) b.clock.done("specular_mip0");
}

// The integrand's hot rows: the summary's when it describes the integrand,
// else made once (the hot split and the tree's chroma floor both read them).
const HotRows& integrand_hot_rows(SourceBake& b) {
    if (b.summary_holds) return b.summary.hot;
    if (!b.integrand_hot) b.integrand_hot = hot_rows(b.integrand);
    return *b.integrand_hot;
}

// The hot split kept, and told in the result.
void set_split(SourceBake& b, HotSplit&& split) {
    b.split = std::move(split);
    b.r.hot_texels = b.split.hot.size();
    b.r.hot_threshold = b.split.threshold;
    b.r.hot_power_fraction = b.split.hot_power_fraction;
}

// The hot texels, integrated exactly by the irradiance and FIS.
void hot_split(SourceBake& b) {
    if (b.want_irr || (b.r1 > 0.0 && b.fis)) {
        set_split(b, split_hot(b.integrand, b.o.hot_threshold, b.o.max_hot, &integrand_hot_rows(b)));
        b.clock.done("hot_split");
    }
    b.advance(0.05);
}

// The hierarchical specular's bin tree, built first: its coarser exact bins
// are the irradiance's too, which then needs no pass of its own.
// The SH9 (SPEC's bilinear L) comes from the tree's reduction, or, without
// a tree, from the same reduction at sh9_bin_width()'s bins: the bins a
// streamed bake reduces (stream_front), so both give the same bits.
void bin_tree(SourceBake& b) {
    const bool need_tree = !b.fis && b.r1 > 0.0;
    b.irr_from_tree = irradiance_from_tree(b.o, need_tree, b.finest_bins);
    if (!need_tree) {
        if (b.irradiance_reads_source()) {
            // The irradiance's own bins are the SH9's (sh9_bin_width): one
            // reduction for both; start_irradiance() takes the hot texels out.
            std::array<Sh9, 3> sh9{};
            b.irr_bins = reduce_to_bins(b.integrand, b.o.irradiance_bins, b.o.irradiance_bins / 2, &sh9);
            set_sh9(b.r, sh9);
        } else {
            set_sh9(b.r, project_sh9_bilinear(b.integrand, sh9_bin_width(b, false)));
        }
        b.clock.done("sh9");
        return;
    }
    b.report("specular", b.done);
    b.r.specular_base_face = b.finest_bins;
    BinTreeOptions tree_options;
    // The integrand's mean per channel: the chroma scores' floor.
    b.channel_mean = channel_means(integrand_hot_rows(b));
    tree_options.channel_mean = b.channel_mean.data();
    std::array<Sh9, 3> sh9{};
    tree_options.sh9 = &sh9;
    // A source this bake owns that nothing reads after the tree (the r = 0
    // levels are made, no export keeps it, the irradiance is the tree's
    // bins') gives its rows back as the tree is done with them, before
    // free_source() frees it: the source, the tree and its per-channel
    // moments are never all held at once (issue 25: +5 MB at forest.exr's
    // peak otherwise).
    std::optional<RowRelease> release;
    if (b.owned && !b.o.extra.keep_source && !b.irradiance_reads_source() &&
        b.integrand.data == b.owned->pixels.data()) {
        release.emplace(*b.owned);
        tree_options.source_done = [&release](int y) { release->before(y); };
    }
    b.tree = build_bin_tree(b.integrand, b.finest_bins, b.irr_from_tree ? &b.irr_bins : nullptr, b.o.irradiance_bins,
                            tree_options);
    set_sh9(b.r, sh9);
    b.clock.done("bin_tree");
}

// On the irradiance's own task: the convolution of the bins and hot points.
void convolve_irradiance(SourceBake& b, int bw, int bh) {
    const auto t0 = std::chrono::steady_clock::now();
    try {
        const BinGroups groups = group_bins(b.irr_bins, bw, bh);
        Cubemap irr(b.o.irradiance_size);
        irradiance_convolve(irr, groups, b.split.hot, b.o.irradiance_exact_face);
        b.irr_saturated = scale_back(irr.pixels, b.scale_exp);
        if (b.o.irradiance) {
            b.r.irradiance = std::move(irr);
            hand_cube(b.sink, "irradiance", *b.r.irradiance, b.source_in_place());
        } else {
            b.r.extra_irradiance = std::move(irr);
        }
    } catch (...) {
        b.irr_error = std::current_exception();
    }
    b.irr_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The irradiance convolution runs beside the specular levels (it reads only
// the bins and the hot points; its own task fills the gaps the levels leave
// between them); join_irradiance() waits for it.
void start_irradiance(SourceBake& b) {
    if (b.want_irr) {
        b.report("irradiance", b.done);
        const int bw = b.o.irradiance_bins, bh = b.o.irradiance_bins / 2;
        // What reads the source is done here: the levels below may free it.
        if (b.irradiance_reads_source() && b.irr_bins.empty()) b.irr_bins = reduce_to_bins(b.integrand, bw, bh);
        remove_hot(b.irr_bins, bw, bh, b.integrand.width, b.integrand.height, b.split);
        b.irr_task.run([&b, bw, bh] { convolve_irradiance(b, bw, bh); });
        b.clock.done("irradiance_start");
    }
    if (!b.o.irradiance) b.skip("irradiance");
}

// FIS: the rest (the source less its hot texels) as a cube pyramid. The rest
// cube must resolve the narrowest lobe (about alpha_1 radians wide) but need
// not be finer than the source.
CubePyramid rest_pyramid(SourceBake& b) {
    const BakeOptions& o = b.o;
    double rf = o.resolved_mip_count() > 1 ? o.mip_roughness(1) : 1.0;
    for (const SpecularLevelRequest& e : o.extra.specular)
        if (e.roughness > 0.0) rf = std::min(rf, e.roughness);
    const double a1 = rf * rf;
    int base = o.specular_base_face;
    if (base == 0)
        base = std::clamp(pow2_ceil(4.0 / a1), 8, std::clamp(pow2_ceil(b.integrand.width / 4.0), 8, 2048));
    b.r.specular_base_face = base;
    Cubemap cube(base);
    const int ss = std::clamp(int(std::ceil(b.integrand.width / (kPi * base))), 1, 4);
    latlong_to_cube(cube, rest_image(b.integrand, b.split), ss);  // on the integration grid
    CubePyramid pyramid = build_pyramid(cube);
    b.clock.done("specular_pyramid");
    return pyramid;
}

// Past the r = 0 levels only the tree is read: a source this bake owns (the
// CLI's, or a cleaned copy) is freed (or kept for an export that asked for
// it) before the rest of the chain is made and written.
void free_source(SourceBake& b) {
    if (b.o.extra.keep_source) b.r.source = std::move(*b.owned);
    FloatBuffer().swap(b.owned->pixels);
    b.owned = nullptr;
    b.luts.start();  // its memory in place of the source's
}

// Levels at nearby roughness in one pass (shared bins and loads).
void integrate_group(SourceBake& b, const std::vector<size_t>& group, const std::string& method_h) {
    const int n = b.jobs[group[0]].face_size;
    std::vector<Cubemap> levels;
    for (size_t k = 0; k < group.size(); ++k) levels.emplace_back(n, Uninitialized{});  // every texel written
    std::vector<SpecularGroupTarget> targets;
    for (size_t k = 0; k < group.size(); ++k) targets.push_back({&levels[k], b.jobs[group[k]].roughness});
    const double bins = specular_hierarchical_group(targets, b.tree, b.o.hierarchical);
    std::string with;
    for (size_t g : group) with += (with.empty() ? "" : ", ") + std::to_string(b.jobs[g].roughness);
    for (size_t k = 0; k < group.size(); ++k)
        b.finish_level(b.jobs[group[k]], std::move(levels[k]), size_t(std::lround(bins)),
                       method_h + ", one pass for roughness " + with);
}

// One level alone: the hierarchical sum over the tree, or FIS of the pyramid.
void integrate_level(SourceBake& b, const LevelJob& job, const CubePyramid& pyramid, const std::string& method_h) {
    Cubemap level(job.face_size, Uninitialized{});  // every texel written
    size_t samples = 0;
    std::string method;
    if (!b.fis) {
        samples = size_t(std::lround(specular_hierarchical(level, b.tree, job.roughness, b.o.hierarchical)));
        method = method_h;
    } else {
        samples = specular_prefilter(level, pyramid, b.split.hot, job.roughness, b.o.specular_quality) +
                  b.split.hot.size();
        method = "filtered importance sampling + hot texels";
    }
    b.finish_level(job, std::move(level), samples, method);
}

// Every level at r > 0, group by group; the LUTs start beside them.
void integrate_specular(SourceBake& b) {
    b.report("specular", b.done);
    CubePyramid pyramid;
    if (b.fis) pyramid = rest_pyramid(b);
    else b.r.specular_kernel = specular_kernel_isa();
    const std::string method_h = "hierarchical second-order kernel sum over exact bins (eps " +
                                 std::to_string(b.o.hierarchical.eps).substr(0, 4) + ", " + b.r.specular_kernel +
                                 " kernel)";
    if (b.fis || !b.owned) b.luts.start();  // no source to free first
    for (const std::vector<size_t>& group : level_groups(b.jobs, !b.fis)) {
        const LevelJob& job = b.jobs[group[0]];
        if (job.roughness == 0.0) continue;  // made by mirror_levels()
        if (!b.fis && b.owned) free_source(b);
        if (group.size() > 1) integrate_group(b, group, method_h);
        else integrate_level(b, job, pyramid, method_h);
    }
    b.clock.done("specular");
}

// The specular levels at r > 0, and what is skipped of SPEC's chain.
void specular_levels(SourceBake& b) {
    if (b.r1 > 0.0) integrate_specular(b);
    if (b.o.specular) skip_levels(b.r, b.o);
    else b.skip("specular");
}

void join_irradiance(SourceBake& b) {
    if (!b.want_irr) return;
    b.irr_task.wait();
    if (b.irr_error) std::rethrow_exception(b.irr_error);
    b.saturated += b.irr_saturated;
    b.r.timings.emplace_back("irradiance", b.irr_seconds);  // its own time, beside the levels
    b.advance(b.w_irr);
    b.clock.done("irradiance_wait");  // what the bake waited for it after the levels
}

void join_luts(SourceBake& b) {
    if (b.o.lut) b.report("brdf_lut", b.done);
    const double lut_seconds = b.luts.join();
    if (b.o.lut) {
        b.clock.done("brdf_lut_wait");                      // what the bake waited for it
        b.r.timings.emplace_back("brdf_lut", lut_seconds);  // its own time, beside the rest
        b.advance(b.w_lut);
    } else {
        b.skip("brdf_lut");
    }
}

// The source kept for an export, the overflow guard undone, the last checks.
void finish_and_check(SourceBake& b) {
    BakeResult& r = b.r;
    // A source kept for an export that was not moved out by free_source()
    // (not owned, or never freed) is copied from the cleaned view.
    if (b.o.extra.keep_source && !r.source) {
        r.source = Image(b.source.width, b.source.height);
        for (int y = 0; y < b.source.height; ++y)
            std::copy_n(b.source.at(0, y), size_t(b.source.width) * 3, r.source->at(0, y));
    }
    if (b.scale_exp != 0) {
        if (r.source) b.rescale(r.source->pixels);
        for (auto& ch : r.sh9)
            for (double& v : ch) v = std::ldexp(v, b.scale_exp);
        for (double& v : r.mean_radiance) v = std::ldexp(v, b.scale_exp);
        r.hot_threshold = std::ldexp(r.hot_threshold, b.scale_exp);
        if (r.sun) {
            for (double& v : r.sun->illuminance) v = std::ldexp(v, b.scale_exp);
            for (double& v : r.sun->removed_power) v = std::ldexp(v, b.scale_exp);
            for (double* v : {&r.sun->peak_luminance, &r.sun->ring_luminance, &r.sun->rival_luminance})
                *v = std::ldexp(*v, b.scale_exp);
        }
    }
    if (b.saturated)
        r.warnings.push_back(std::to_string(b.saturated) +
                             " output values exceeded the float range and were saturated at 3.4e38");
    warn_if_black(r);
    check_outputs(r, b.source_in_place());
    if (b.sink) b.sink->wait();
    b.report("done", 1.0);
}

// Rows decoded into one of two band buffers while the other's rows are
// reduced (a reader thread, unless one thread was asked for). Before a
// buffer is reused, its band's last `keep` rows go to a tail: a bin row
// reads up to max_reach() = keep + 1 rows, across a band's start. Bands
// are at least keep + 1 rows high.
// A source of halves (has_halves()) is read into two buffers of halves,
// and its floats are written by the pass that reduces them (halves()),
// into a ring of band + keep rows (row y at slot y mod (band + keep)): the
// rows a band's bins still need from the band before stay where they are.
// Its reader is one thread for the whole pass, which starts band k + 1 as
// soon as band k - 1's halves are made floats (halves_done(), before the
// rest of that band is reduced), so that the decoder is never waiting for
// a band's last reductions, nor they for its last blocks.
class BandRing {
public:
    BandRing(BandSource& src, int band, int keep, bool overlap)
        : src_(src), w_(src.width()), h_(src.height()), band_(band), keep_(keep), overlap_(overlap),
          halves_(src.has_halves()), row_(size_t(w_) * 3), table_(size_t(h_), nullptr) {
        if (band_ <= keep_) throw std::logic_error("BandRing: bands must be higher than the rows kept");
        const size_t band_values = size_t(std::min(band_, h_)) * row_;
        if (halves_) {
            slots_ = std::min(band_ + keep_, h_);
            buf_[0].resize(size_t(slots_) * row_);
            for (auto& r : raw_) r.resize(band_values);
        } else {
            for (auto& b : buf_) b.resize(band_values);
            tail_.resize(size_t(keep_) * row_);
        }
    }
    BandRing(const BandRing&) = delete;
    BandRing& operator=(const BandRing&) = delete;
    ~BandRing() {
        {
            std::lock_guard<std::mutex> lock(m_);
            stop_ = true;
        }
        cv_.notify_all();
        join();
    }

    // For a source of halves read by the reader thread: starts it, so that
    // band 0 is decoded while the caller makes its reducers (next() starts
    // it otherwise).
    void start() {
        if (streaming() && !reader_.joinable() && next_y_ < h_) reader_ = std::thread([this] { read_ahead(); });
    }
    // The next band: its rows (to be cleaned in place), first row and count; false after the last.
    bool next(std::vector<float*>& rows, int& y0, int& n) {
        if (next_y_ >= h_) return false;
        const int cur = k_ & 1;
        if (k_ == 0) {
            if (streaming()) start();
            else read_into(cur, 0);
        }
        if (streaming()) {
            std::exception_ptr failed;  // band k's read, not a later one's
            {
                std::unique_lock<std::mutex> lock(m_);
                cv_.wait(lock, [this] { return read_ >= k_ || error_; });  // band k in buffer cur
                if (read_ < k_) failed = error_;
            }
            if (failed) std::rethrow_exception(failed);
        } else {
            join();  // band k was being read into buffer cur
            if (error_) std::rethrow_exception(error_);
        }
        y0 = next_y_;
        n = std::min(band_, h_ - y0);
        std::fill(table_.begin() + have0_, table_.begin() + (have1_ + 1), nullptr);
        have0_ = k_ == 0 ? 0 : y0 - keep_;
        for (int y = have0_; y < y0; ++y)
            table_[size_t(y)] = halves_ ? slot(y) : tail_.data() + size_t(y - have0_) * row_;
        rows.resize(size_t(n));
        for (int k = 0; k < n; ++k) {
            rows[size_t(k)] = halves_ ? slot(y0 + k) : buf_[cur].data() + size_t(k) * row_;
            table_[size_t(y0 + k)] = rows[size_t(k)];
        }
        cur_halves_ = halves_ ? raw_[cur].data() : nullptr;
        have1_ = y0 + n - 1;
        next_y_ = y0 + n;
        ++k_;
        if (streaming()) return true;
        if (next_y_ < h_ && overlap_) {
            const int other = k_ & 1, start = next_y_;
            reader_ = std::thread([this, other, start] {
                try {
                    read_into(other, start);
                } catch (...) {
                    error_ = std::current_exception();
                }
            });
        }
        return true;
    }
    // The band's rows as halves, rows x width x 3, when the source gives
    // halves: the rows next() returned are then to be filled from them (null otherwise).
    const uint16_t* halves() const { return cur_halves_; }
    // The band's halves are made floats: its buffer may take the band after next.
    void halves_done() {
        if (!streaming()) return;
        {
            std::lock_guard<std::mutex> lock(m_);
            freed_ = k_ - 1;
        }
        cv_.notify_all();
    }
    // After a band is reduced: its last rows to the tail, and (without the
    // reader thread) the next band read.
    void done() {
        halves_done();  // if the pass did not say so
        if (next_y_ >= h_) return;
        if (streaming()) return;
        if (!halves_) {
            const float* last = buf_[(k_ - 1) & 1].data() + size_t(band_ - keep_) * row_;  // a band before the last is whole
            std::memcpy(tail_.data(), last, size_t(keep_) * row_ * sizeof(float));
        }
        if (!overlap_) read_into(k_ & 1, next_y_);
    }
    // Rows have0() .. have1() through the row table (null elsewhere).
    ImageView view() const {
        ImageView v(nullptr, w_, h_);
        v.rows = table_.data();
        return v;
    }
    int have0() const { return have0_; }
    int have1() const { return have1_; }

private:
    float* slot(int y) { return buf_[0].data() + size_t(y % slots_) * row_; }
    bool streaming() const { return halves_ && overlap_; }
    // The reader thread of a source of halves: band j into buffer j & 1 once
    // band j - 2 is made floats, bands 0 .. the last in turn.
    void read_ahead() {
        for (int j = 0;; ++j) {
            const int y0 = j * band_;
            if (y0 >= h_) return;
            {
                std::unique_lock<std::mutex> lock(m_);
                cv_.wait(lock, [this, j] { return freed_ >= j - 2 || stop_; });
                if (stop_) return;
            }
            try {
                read_into(j & 1, y0);
            } catch (...) {
                std::lock_guard<std::mutex> lock(m_);
                error_ = std::current_exception();
                cv_.notify_all();
                return;
            }
            {
                std::lock_guard<std::mutex> lock(m_);
                read_ = j;
            }
            cv_.notify_all();
        }
    }
    void read_into(int which, int y0) {
        const int n = std::min(band_, h_ - y0);
        if (halves_) src_.read_halves(y0, n, raw_[which].data());
        else src_.read(y0, n, buf_[which].data());
    }
    void join() {
        if (reader_.joinable()) reader_.join();
    }

    BandSource& src_;
    const int w_, h_, band_, keep_;
    const bool overlap_, halves_;
    const size_t row_;
    int slots_ = 0;
    // Not zeroed: every row is written before it is read (62 MB at 16K,
    // zeroed by one thread before the first read could start, was 35 ms).
    BigVector<float> buf_[2], tail_;
    BigVector<uint16_t> raw_[2];
    const uint16_t* cur_halves_ = nullptr;
    std::vector<const float*> table_;
    std::thread reader_;
    std::exception_ptr error_;
    int k_ = 0, next_y_ = 0, have0_ = 0, have1_ = -1;
    // The reader of halves and the pass: the last band read, the last band
    // whose halves are floats, and the pass's end.
    std::mutex m_;
    std::condition_variable cv_;
    int read_ = -1, freed_ = -1;
    bool stop_ = false;
};

// The bins a streamed pass reduces (BandReducers), by width (0: none): the
// tree's finest, the irradiance's own when the tree's are too coarse for
// it, and, when neither is reduced, bins for the SH9 alone.
struct StreamBins {
    int tree = 0, irr = 0, sh9 = 0;
    std::array<int, 3> widths() const { return {tree, irr, sh9}; }
};
StreamBins stream_bins(const SourceBake& b) {
    StreamBins s;
    const bool need_tree = b.r1 > 0.0;
    if (need_tree) s.tree = b.finest_bins;
    if (b.want_irr && !irradiance_from_tree(b.o, need_tree, b.finest_bins)) s.irr = b.o.irradiance_bins;
    if (!s.tree && !s.irr) s.sh9 = sh9_bin_width(b, need_tree);
    return s;
}

// The most source rows a bin row of those reads (BandReducers::reach()).
int stream_reach(const SourceBake& b, int h) {
    int r = 1;
    for (int w : stream_bins(b).widths())
        if (w) r = std::max(r, BinRowStream::reach(h, w));
    return r;
}

// What a streamed pass reduces each band into: the summary (SummaryStream),
// the hot texels (HotStream), the finest bins' rows (BinRowStream; a second
// one at the irradiance's own bins when the tree's are too coarse for it)
// and mip 0's lookups (MirrorStream).
struct BandReducers {
    BandReducers(SourceBake& b, int w, int h) : sums(w, h) {
        if (b.want_irr) hots = std::make_unique<HotStream>(w, h, b.o.max_hot);
        need_tree = b.r1 > 0.0;
        b.irr_from_tree = irradiance_from_tree(b.o, need_tree, b.finest_bins);
        const StreamBins s = stream_bins(b);
        if (s.tree) bins = std::make_unique<BinRowStream>(w, h, s.tree);
        if (s.irr) irr_bins = std::make_unique<BinRowStream>(w, h, s.irr, /*sh9=*/!bins);  // sh9()'s choice
        if (s.sh9) sh9_bins = std::make_unique<BinRowStream>(w, h, s.sh9);
        size_t mirror_jobs = 0;
        for (const LevelJob& job : b.jobs) mirror_jobs += job.roughness == 0.0;
        mirrors.reserve(mirror_jobs);  // the streams hold references
        for (const LevelJob& job : b.jobs)
            if (job.roughness == 0.0) {
                mirrors.emplace_back(job.face_size, Uninitialized{});  // every texel written
                mirror_streams.push_back(std::make_unique<MirrorStream>(mirrors.back(), w, h));
            }
    }
    // Rows above a band the bin rows still need (their reach).
    int reach() const {
        int r = 1;
        for (const auto* s : {bins.get(), irr_bins.get(), sh9_bins.get()})
            if (s) r = std::max(r, s->max_reach());
        return r;
    }
    void add(BandRing& ring, float* const* rows, int y0, int n) {
        sums.add_rows(rows, y0, n, hots.get(), ring.halves());  // each row to hots too, while in the cache
        ring.halves_done();
        const ImageView v = ring.view();
        for (auto* s : {bins.get(), irr_bins.get(), sh9_bins.get()})
            if (s) s->add_rows(v, ring.have0(), ring.have1());
        for (auto& m : mirror_streams) m->add_rows(v, ring.have0(), ring.have1());
    }
    void check_finished() const {
        for (const auto* s : {bins.get(), irr_bins.get(), sh9_bins.get()})
            if (s && s->pending() != 0) throw std::logic_error("streamed bake: bin rows left unreduced");
        for (const auto& m : mirror_streams)
            if (m->pending() != 0) throw std::logic_error("streamed bake: mip 0 texels left unread");
    }

    // The SH9 of SPEC's L from the first bins there are (project_sh9_bilinear
    // at sh9_bin_width(): what a whole bake reports).
    std::array<Sh9, 3> sh9() const { return (bins ? bins : irr_bins ? irr_bins : sh9_bins)->sh9(); }

    SummaryStream sums;
    std::unique_ptr<HotStream> hots;
    bool need_tree = false;
    std::unique_ptr<BinRowStream> bins, irr_bins, sh9_bins;
    std::vector<Cubemap> mirrors;
    std::vector<std::unique_ptr<MirrorStream>> mirror_streams;
};

// The pass over the source's bands, two buffers deep (a reader thread
// decodes band k+1 while band k is reduced).
void read_bands(SourceBake& b, BandRing& ring, int h, BandReducers& red) {
    std::vector<float*> rows;
    int y0 = 0, n = 0;
    while (ring.next(rows, y0, n)) {
        red.add(ring, rows.data(), y0, n);
        ring.done();
        // The last band's value is exactly where advance() puts b.done after the pass (no rounding backwards).
        b.report("reading source", y0 + n == h ? b.done + 0.05 / b.w_total
                                               : b.done + 0.05 / b.w_total * double(y0 + n) / h);
    }
}

// scan() .. bin_tree() for a source read in bands (compute_bake_stream):
// each band reduced as it comes (BandReducers), then what needs the whole
// source's sums (the strict check, the mean, the hot threshold, the tree).
// False when the overflow guard is needed (nothing handed to the sink yet).
bool stream_front(SourceBake& b, BandSource& src) {
    BakeResult& r = b.r;
    const int w = src.width(), h = src.height();
    b.streamed = true;
    option_warnings(r, b.o);
    aspect_warning(r, w, h);
    b.report("reading source", 0.0);
    plan_levels(b);
    // The bands, sized for the rows the bin rows reach, and the first read
    // while the reducers are made (44 ms at 16K: the mip 0 lookups' sort,
    // the hat tables).
    const int reach = stream_reach(b, h);
    const int keep = std::max(1, reach - 1);
    const int band = std::max({src.preferred_band(), reach, keep + 1, 16});
    BandRing ring(src, band, keep, b.o.threads != 1);
    ring.start();
    BandReducers red(b, w, h);
    if (red.reach() != reach) throw std::logic_error("streamed bake: the bands do not hold the rows a bin row reads");
    read_bands(b, ring, h, red);
    b.advance(0.05);  // hot_split()'s share, done here
    red.check_finished();
    b.summary = red.sums.finish();
    r.bad_input = b.summary.scan.bad;
    check_strict(r, b.o);
    b.scale_exp = overflow_guard_exponent(b.summary.scan.max_value);
    if (b.scale_exp != 0) return false;
    b.clock.done("read");
    // integration_grid(): the summary describes the cleaned source, the integrand.
    b.source = b.integrand = ImageView(nullptr, w, h);
    b.summary_holds = true;
    r.integration_width = w;
    r.integration_height = h;
    set_sh9(r, red.sh9());
    // mirror_levels()
    size_t m = 0;
    for (const LevelJob& job : b.jobs) {
        if (job.roughness != 0.0) continue;
        b.report("specular", b.done);
        b.finish_level(job, std::move(red.mirrors[m++]), 1, "bilinear source lookup");
    }
    // hot_split()
    if (b.want_irr) set_split(b, red.hots->finish(b.o.hot_threshold, b.summary.hot));
    // bin_tree(), and the bins start_irradiance() takes the hot texels from
    // (reduce_rest_to_bins's reduction when the tree's do not serve).
    if (red.irr_bins) b.irr_bins = red.irr_bins->take_bins();
    if (!red.need_tree) return true;
    b.report("specular", b.done);
    r.specular_base_face = b.finest_bins;
    BinTreeOptions tree_options;
    b.channel_mean = channel_means(b.summary.hot);
    tree_options.channel_mean = b.channel_mean.data();
    b.tree = red.bins->finish(b.channel_mean.data(), b.irr_from_tree ? &b.irr_bins : nullptr,
                              b.o.irradiance_bins, tree_options);
    b.clock.done("bin_tree");
    return true;
}

// The stages after the bin tree, the same for a whole and a streamed source.
BakeResult bake_from_irradiance(SourceBake& b) {
    start_irradiance(b);
    specular_levels(b);
    join_irradiance(b);
    join_luts(b);
    finish_and_check(b);
    return std::move(b.r);
}

// The bake of `view`. `owned`, when given, holds the same pixels and may be
// cleaned in place; otherwise a source that needs cleaning is copied first
// and a clean one is read where it lies.
BakeResult bake_source(ImageView view, Image* owned, const BakeOptions& o, const ProgressFn& progress,
                       LutCache* lut_cache, OutputSink* sink) {
    o.validate();
    if (view.width < 1 || view.height < 1) throw std::invalid_argument("source image is empty");
    return in_arena(o.threads, [&] {
        SourceBake b(view, owned, o, progress, lut_cache, sink);
        scan(b);
        sanitize(b);
        orient(b);
        split_sun_stage(b);
        integration_grid(b);
        plan_levels(b);
        mirror_levels(b);
        hot_split(b);
        bin_tree(b);
        return bake_from_irradiance(b);
    });
}

}  // namespace

std::string whole_source_reason(const BakeOptions& o) {
    if (o.rotation != 0.0) return "the world is turned (rotation)";
    if (o.sun == SunMode::Split) return "the sun is split from the sky";
    if (o.specular_method != SpecularMethod::Hierarchical) return "filtered importance sampling";
    if (o.extra.keep_source) return "an export keeps the source";
    return "";
}

double stream_state_bytes(const BakeOptions& o) {
    const std::vector<LevelJob> jobs = level_jobs(o);
    const bool need_tree = smallest_positive_roughness(jobs) > 0.0, want_irr = o.irradiance || o.extra.irradiance;
    const int finest = finest_bin_width(o);
    const double bin = double(sizeof(Bin));
    double bytes = 0.0;
    if (need_tree) bytes += bin * finest * (finest / 2);
    if (want_irr && !irradiance_from_tree(o, need_tree, finest))
        bytes += bin * o.irradiance_bins * (o.irradiance_bins / 2);
    for (const LevelJob& j : jobs)
        if (j.roughness == 0.0) bytes += 52.0 * j.face_size * j.face_size;  // MirrorStream's coordinates and buckets
    return bytes;
}

std::optional<BakeResult> compute_bake_stream(BandSource& source, const BakeOptions& o, const ProgressFn& progress,
                                              LutCache* lut_cache, OutputSink* sink) {
    o.validate();
    const std::string why = whole_source_reason(o);
    if (!why.empty()) throw std::invalid_argument("compute_bake_stream: the whole source is needed: " + why);
    if (source.width() < 1 || source.height() < 1) throw std::invalid_argument("source image is empty");
    return in_arena(o.threads, [&]() -> std::optional<BakeResult> {
        SourceBake b(ImageView(nullptr, source.width(), source.height()), nullptr, o, progress, lut_cache, sink);
        if (!stream_front(b, source)) return std::nullopt;
        return bake_from_irradiance(b);
    });
}

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
        if (o.sun == SunMode::Split) {
            r.sun = SunLight{};
            r.sun->why = "no compact source: a plain colour lights evenly from every direction";
        }
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
            if (sink) sink->lut(*r.lut, r.lut_sha256);
            clock.done("brdf_lut");
        } else {
            r.skipped.push_back(skip_reason(o, "brdf_lut", "disabled by option"));
        }
        extra_lut_stage(r, o, lut_cache);
        warn_if_black(r);
        check_outputs(r, false);
        if (sink) sink->wait();
        report("done", 1.0);
        return r;
    });
}

}  // namespace iblbake
