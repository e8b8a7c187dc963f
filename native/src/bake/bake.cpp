#include "iblbake/bake/bake.h"

#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>

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

// Finest specular bins: small enough for every level's lobe (radius <=
// min(level eps, finest_eps) * 2 alpha, about 2.2 / (eps alpha) bins across)
// and horizon rule (radius <= hierarchical_horizon_radius), a power of two,
// at most 4096 across.
int finest_bin_width(const BakeOptions& o) {
    const int mips = o.resolved_mip_count();
    if (!o.specular || mips < 2 || o.specular_method != SpecularMethod::Hierarchical || o.resolved_last_level() < 1)
        return 2;
    double radius = kPi;
    for (int m = std::max(1, o.first_level); m <= o.resolved_last_level(); ++m) {
        const double r = o.mip_roughness(m);
        const int n = std::max(1, o.face_size >> m);
        const double e = std::min(hierarchical_level_eps(o.hierarchical, n), o.hierarchical.finest_eps);
        if (r > 0.0) radius = std::min({radius, e * 2.0 * r * r, hierarchical_horizon_radius(r, n, o.hierarchical)});
    }
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
          "specular eps must be in 0.02..2 (the default 0.4 keeps every texel within about 0.3 %; error grows as eps^3 to eps^4)");
    check(hierarchical.tile >= 1 && hierarchical.tile <= 256, "specular tile must be in 1..256");
    check(irradiance_exact_face >= 1 && irradiance_exact_face <= 4096, "irradiance_exact_face must be in 1..4096");
    check(std::isfinite(hot_threshold) && hot_threshold >= 1.0, "hot_threshold must be >= 1");
    check(max_hot >= 0 && max_hot <= 1 << 20, "max_hot must be in 0..1048576");
    check(threads >= 0 && threads <= 1024, "threads must be in 0..1024 (0: all cores)");
    const int mips = resolved_mip_count();
    check(first_level >= 0 && first_level < mips, "first_level must be in 0..mip_count-1");
    check(last_level == -1 || (last_level >= first_level && last_level < mips),
          "last_level must be -1 (the last) or in first_level..mip_count-1");
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
    return in_arena(o.threads, [&] {
        BakeResult r;
        const SinkGuard guard{sink};  // destroyed before r: what the sink reads outlives it
        StageClock clock(r);
        auto report = [&](const std::string& stage, double f) {
            if (progress && !progress(stage, f)) throw Cancelled();
        };
        const int mips = o.resolved_mip_count();
        // Rough share of the work per stage, for the progress bar.
        const double w_irr = o.irradiance ? 0.15 : 0.0, w_lut = o.lut ? 0.25 : 0.0;
        const double w_spec = o.specular ? 0.6 : 0.0, w_total = 0.05 + w_irr + w_spec + w_lut;
        double done = 0.0;
        auto advance = [&](double w) { done += w / w_total; };

        report("reading source", 0.0);
        const SourceScan scan = scan_source(view);
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
        r.sh9 = project_sh9(integrand);
        // The mean is the constant band: L_00 = integral of L / (2 sqrt(pi)).
        for (int c = 0; c < 3; ++c) r.mean_radiance[c] = r.sh9[c][0] / (2.0 * std::sqrt(kPi));
        clock.done("sh9");

        // Outputs are final once made: scaled back (the overflow guard) and
        // handed to the sink, which may start writing them at once.
        auto finished = [&](std::vector<float>& px) {
            if (scale_exp != 0)
                for (float& v : px) v = std::ldexp(v, scale_exp);
        };
        const bool fis = o.specular_method == SpecularMethod::Fis;
        const int first = o.first_level, last = o.resolved_last_level();
        if (o.specular) {
            r.specular.reserve(size_t(last - first + 1));  // the sink holds references into it
            r.specular_levels.reserve(size_t(last - first + 1));
        }
        auto specular_done = [&](Cubemap&& level, int m, double rough) {
            finished(level.pixels);
            r.specular.push_back(std::move(level));
            r.specular_levels.push_back(m);
            r.roughness.push_back(rough);
            if (sink) sink->cube("specular_" + std::to_string(m), r.specular.back());
            advance(w_spec / (last - first + 1));
            report("specular", done);
        };

        // Mip 0 (r = 0 by default) first: the largest file, whose writing
        // then overlaps everything that follows.
        int next = first;
        if (o.specular && o.mip_roughness(first) == 0.0) {
            report("specular", done);
            Cubemap level(std::max(1, o.face_size >> first));
            specular_mirror(level, source);
            r.samples_per_texel.push_back(1);
            r.specular_methods.push_back("bilinear source lookup");
            specular_done(std::move(level), first, 0.0);
            next = first + 1;
            clock.done("specular_mip0");
        }

        const bool need_split =
            o.irradiance || (o.specular && mips > 1 && o.specular_method == SpecularMethod::Fis);
        HotSplit split;
        if (need_split) {
            split = split_hot(integrand, o.hot_threshold, o.max_hot);
            r.hot_texels = split.hot.size();
            r.hot_threshold = split.threshold;
            r.hot_power_fraction = split.hot_power_fraction;
            clock.done("hot_split");
        }
        advance(0.05);

        auto skip = [&](const char* what) { r.skipped.push_back(skip_reason(o, what, "disabled by option")); };

        // The hierarchical specular's bin tree, built first: its coarser exact
        // bins are the irradiance's too, which then needs no pass of its own.
        const bool need_tree = o.specular && !fis && mips > 1 && last > 0;
        const bool irr_from_tree = o.irradiance && need_tree && o.irradiance_bins <= finest_bins / 4;
        BinTree tree;
        std::vector<Bin> irr_bins;
        if (need_tree) {
            report("specular", done);
            r.specular_base_face = finest_bins;
            tree = build_bin_tree(integrand, finest_bins, irr_from_tree ? &irr_bins : nullptr, o.irradiance_bins);
            clock.done("bin_tree");
        }

        if (o.irradiance) {
            report("irradiance", done);
            const int bw = o.irradiance_bins, bh = o.irradiance_bins / 2;
            if (irr_from_tree) remove_hot(irr_bins, bw, bh, integrand.width, integrand.height, split);
            else irr_bins = reduce_rest_to_bins(integrand, split, bw, bh);
            const BinGroups groups = group_bins(irr_bins, bw, bh);
            Cubemap irr(o.irradiance_size);
            irradiance_convolve(irr, groups, split.hot, o.irradiance_exact_face);
            finished(irr.pixels);
            r.irradiance = std::move(irr);
            if (sink) sink->cube("irradiance", *r.irradiance);
            clock.done("irradiance");
            advance(w_irr);
        } else {
            skip("irradiance");
        }

        if (o.specular) {
            report("specular", done);
            CubePyramid pyramid;
            if (mips > 1 && fis) {
                // The rest cube must resolve the narrowest lobe (about alpha_1
                // radians wide) but need not be finer than the source.
                const double r1 = o.mip_roughness(1), a1 = r1 * r1;
                int base = o.specular_base_face;
                if (base == 0)
                    base = std::clamp(pow2_ceil(4.0 / a1), 8, std::clamp(pow2_ceil(integrand.width / 4.0), 8, 2048));
                r.specular_base_face = base;
                Cubemap cube(base);
                const int ss = std::clamp(int(std::ceil(integrand.width / (kPi * base))), 1, 4);
                latlong_to_cube(cube, rest_image(integrand, split), ss);  // on the integration grid
                pyramid = build_pyramid(cube);
                clock.done("specular_pyramid");
            }
            for (int m = next; m <= last; ++m) {
                const int n = std::max(1, o.face_size >> m);
                const double rough = o.mip_roughness(m);
                if (rough > 0.0 && !fis && owned) {
                    // Past mip 0 only the tree is read: a source this bake owns
                    // (the CLI's, or a cleaned copy) is freed before the rest
                    // of the chain is made and written.
                    std::vector<float>().swap(owned->pixels);
                    owned = nullptr;
                }
                Cubemap level(n);
                if (rough == 0.0) {
                    specular_mirror(level, source);
                    r.samples_per_texel.push_back(1);
                    r.specular_methods.push_back("bilinear source lookup");
                } else if (!fis) {
                    const double bins = specular_hierarchical(level, tree, rough, o.hierarchical);
                    r.samples_per_texel.push_back(size_t(std::lround(bins)));
                    r.specular_methods.push_back("hierarchical second-order kernel sum over exact bins (eps " +
                                                 std::to_string(o.hierarchical.eps).substr(0, 4) + ")");
                } else {
                    const size_t samples = specular_prefilter(level, pyramid, split.hot, rough, o.specular_quality);
                    r.samples_per_texel.push_back(samples + split.hot.size());
                    r.specular_methods.push_back("filtered importance sampling + hot texels");
                }
                specular_done(std::move(level), m, rough);
            }
            skip_levels(r, o);
            clock.done("specular");
        } else {
            skip("specular");
        }

        if (o.lut) {
            report("brdf_lut", done);
            lut_stage(r, o, lut_cache);
            if (sink) sink->lut(*r.lut);
            clock.done("brdf_lut");
            advance(w_lut);
        } else {
            skip("brdf_lut");
        }
        if (scale_exp != 0) {
            for (auto& ch : r.sh9)
                for (double& v : ch) v = std::ldexp(v, scale_exp);
            for (double& v : r.mean_radiance) v = std::ldexp(v, scale_exp);
            r.hot_threshold = std::ldexp(r.hot_threshold, scale_exp);
        }
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
        if (sink) sink->wait();
        report("done", 1.0);
        return r;
    });
}

}  // namespace iblbake
