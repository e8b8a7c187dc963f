// iblbake_accuracy SOURCE [options]: bakes SOURCE with the default options
// (or those given) and measures every output against the exhaustive
// reference of SPEC's integral over the bilinear source
// (tests/native/reference.h), printing one row per output: issue 14's
// per-texel metric e = |out - ref| / max(ref, 0.05 x mean) on the channel
// sums ("sum": max e, solid-angle RMS of the error relative to the
// reference's, energy bias), and beside it issue 25's per-channel metric
// ("per channel": e_c = |out_c - ref_c| / max(ref_c, 0.05 x mean_c), mean_c
// the mean of channel c; max and p99 of e, saRMS and |bias| each the largest
// over the three channels, with the channel of the max). Max and p99 are over
// every texel of small levels and every texel near a bright feature of large
// ones; saRMS and bias over the uniform random sample. Not a test: a
// measuring tool for closing notes and benchmarks.
//
//   --face N --mips M --irradiance-size N --eps X --tile T --chroma X
//   --irradiance-bins N --hot-threshold X --max-hot N         bake options
//   --per-level K     random texels per large level (default 300)
//   --small-face S    levels of face <= S are measured at every texel (default 32)
//   --ref-cache FILE  keep the reference values (RGB) there (computed once per
//                     source, texel set and face size; reused when they match)
//   --worst K         list the K worst texels of each output (per channel)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "iblbake/bake/bake.h"
#include "iblbake/ibl/source.h"
#include "iblbake/io/image_io.h"
#include "iblbake/math/cube.h"
#include "iblbake/util/parallel.h"
#include "reference.h"

using namespace iblbake;

namespace {

struct Output {
    std::string name;
    int n;
    double roughness;  // < 0: irradiance
    std::vector<ref::MeasureTexel> texels;
    std::vector<ref::Rgb> ref;
};

double channel_sum(const float* v) { return double(v[0]) + v[1] + v[2]; }
double channel_sum(const ref::Rgb& v) { return v[0] + v[1] + v[2]; }
constexpr char kChannel[3] = {'R', 'G', 'B'};

// Reference cache: a header naming the format (RGB values), the source size
// and every texel, then the values.
constexpr int kCacheMagic = 0x52474231;  // "RGB1"
bool load_cache(const std::string& path, int w, int h, std::vector<Output>& outs) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return false;
    int hdr[4];
    if (!f.read(reinterpret_cast<char*>(hdr), sizeof(hdr)) || hdr[0] != kCacheMagic || hdr[1] != w || hdr[2] != h ||
        hdr[3] != int(outs.size()))
        return false;
    for (Output& o : outs) {
        int m[2];
        if (!f.read(reinterpret_cast<char*>(m), sizeof(m)) || m[0] != o.n || m[1] != int(o.texels.size())) return false;
        std::vector<int> ij(3 * o.texels.size());
        if (!f.read(reinterpret_cast<char*>(ij.data()), std::streamsize(ij.size() * sizeof(int)))) return false;
        for (size_t k = 0; k < o.texels.size(); ++k)
            if (ij[3 * k] != o.texels[k].t.f || ij[3 * k + 1] != o.texels[k].t.i || ij[3 * k + 2] != o.texels[k].t.j)
                return false;
        double rough;
        if (!f.read(reinterpret_cast<char*>(&rough), sizeof(rough)) || rough != o.roughness) return false;
        o.ref.resize(o.texels.size());
        if (!f.read(reinterpret_cast<char*>(o.ref.data()), std::streamsize(o.ref.size() * sizeof(ref::Rgb)))) return false;
    }
    return true;
}

void store_cache(const std::string& path, int w, int h, const std::vector<Output>& outs) {
    std::ofstream f(path + ".tmp", std::ios::binary);
    const int hdr[4] = {kCacheMagic, w, h, int(outs.size())};
    f.write(reinterpret_cast<const char*>(hdr), sizeof(hdr));
    for (const Output& o : outs) {
        const int m[2] = {o.n, int(o.texels.size())};
        f.write(reinterpret_cast<const char*>(m), sizeof(m));
        std::vector<int> ij;
        for (const auto& t : o.texels) ij.insert(ij.end(), {t.t.f, t.t.i, t.t.j});
        f.write(reinterpret_cast<const char*>(ij.data()), std::streamsize(ij.size() * sizeof(int)));
        f.write(reinterpret_cast<const char*>(&o.roughness), sizeof(o.roughness));
        f.write(reinterpret_cast<const char*>(o.ref.data()), std::streamsize(o.ref.size() * sizeof(ref::Rgb)));
    }
    f.close();
    std::rename((path + ".tmp").c_str(), path.c_str());
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr,
                     "usage: iblbake_accuracy SOURCE [--face N] [--mips M] [--irradiance-size N] [--eps X] [--tile T] [--chroma X]\n"
                     "       [--irradiance-bins N] [--hot-threshold X] [--max-hot N]\n"
                     "       [--per-level K] [--small-face S] [--ref-cache FILE] [--worst K]\n");
        return 2;
    }
    BakeOptions o;
    int per_level = 300, small_face = 32, worst = 0;
    std::string cache;
    for (int a = 2; a + 1 < argc; a += 2) {
        const std::string k = argv[a];
        const double v = std::atof(argv[a + 1]);
        if (k == "--face") o.face_size = int(v);
        else if (k == "--mips") o.mip_count = int(v);
        else if (k == "--irradiance-size") o.irradiance_size = int(v);
        else if (k == "--per-level") per_level = int(v);
        else if (k == "--small-face") small_face = int(v);
        else if (k == "--eps") o.hierarchical.eps = v;
        else if (k == "--tile") o.hierarchical.tile = int(v);
        else if (k == "--finest-eps") o.hierarchical.finest_eps = v;
        else if (k == "--horizon") o.hierarchical.horizon = v;
        else if (k == "--chroma") o.hierarchical.chroma = v;
        else if (k == "--irradiance-bins") o.irradiance_bins = int(v);
        else if (k == "--hot-threshold") o.hot_threshold = v;
        else if (k == "--max-hot") o.max_hot = int(v);
        else if (k == "--ref-cache") cache = argv[a + 1];
        else if (k == "--worst") worst = int(v);
        else { std::fprintf(stderr, "unknown option %s\n", k.c_str()); return 2; }
    }
    o.lut = false;  // the LUT has its own reference tests
    io::LoadedImage li = io::read_image(argv[1]);
    Image src = li.image;
    sanitize(src);
    const auto t0 = std::chrono::steady_clock::now();
    const BakeResult r = compute_bake(li.image, o);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    const ref::TexelTable table = ref::texel_table(src);
    const ref::Rgb mean3 = ref::mean_radiance(table);
    const double mean = mean3[0] + mean3[1] + mean3[2];
    const std::vector<ref::BrightFeature> bright = ref::bright_features(src);

    std::vector<Output> outs;
    std::vector<const Cubemap*> cubes;
    if (r.irradiance) {
        outs.push_back({"irradiance", r.irradiance->size, -1.0,
                        ref::measure_texels(r.irradiance->size, 1.0, {}, per_level, small_face, 1), {}});
        cubes.push_back(&*r.irradiance);
    }
    for (size_t m = 0; m < r.specular.size(); ++m) {
        const int n = r.specular[m].size;
        outs.push_back({"specular_" + std::to_string(r.specular_levels[m]), n, r.roughness[m],
                        ref::measure_texels(n, r.roughness[m], bright, per_level, small_face, unsigned(m + 2)), {}});
        cubes.push_back(&r.specular[m]);
    }
    const bool cached = !cache.empty() && load_cache(cache, src.width, src.height, outs);
    const auto t1 = std::chrono::steady_clock::now();
    if (!cached) {
        struct Job { size_t o, k; };
        std::vector<Job> jobs;
        for (size_t q = 0; q < outs.size(); ++q) {
            outs[q].ref.assign(outs[q].texels.size(), ref::Rgb{0, 0, 0});
            for (size_t k = 0; k < outs[q].texels.size(); ++k) jobs.push_back({q, k});
        }
        parallel_for(0, int(jobs.size()), [&](int j) {
            Output& q = outs[jobs[j].o];
            const ref::CubeTexel& t = q.texels[jobs[j].k].t;
            const Vec3d n = texel_direction(t.f, t.i, t.j, q.n);
            q.ref[jobs[j].k] = q.roughness < 0 ? ref::irradiance(table, n) : ref::prefiltered(table, n, q.roughness);
        });
        if (!cache.empty()) store_cache(cache, src.width, src.height, outs);
    }
    const double ref_secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();

    std::printf("source %s (%dx%d), mean %.4g (R %.4g G %.4g B %.4g), %zu bright features; bake without LUT %.3f s; "
                "reference %s %.1f s\n",
                argv[1], src.width, src.height, mean, mean3[0], mean3[1], mean3[2], bright.size(), secs,
                cached ? "read from cache" : "computed", ref_secs);
    std::printf("%-12s %5s %6s %6s | %-29s | %-40s | %6s  %s\n", "", "", "", "", "sum of channels",
                "per channel (max over R, G, B)", "", "");
    std::printf("%-12s %5s %6s %6s | %9s %9s %9s | %11s %9s %9s %9s | %6s  %s\n", "output", "face", "rough", "n",
                "max e", "saRMS", "bias", "max e", "p99 e", "saRMS", "bias", "bins",
                "worst texel (f i j ch: ref, out, deg from brightest)");
    auto degrees = [&](const ref::CubeTexel& t, int n) {
        const Vec3d d = texel_direction(t.f, t.i, t.j, n);
        return bright.empty() ? -1.0 : std::acos(std::clamp(dot(d, bright[0].dir), -1.0, 1.0)) * 180 / kPi;
    };
    for (size_t q = 0; q < outs.size(); ++q) {
        const Output& oq = outs[q];
        std::vector<ref::Rgb> vals;
        std::vector<double> vsum, rsum;
        for (size_t k = 0; k < oq.texels.size(); ++k) {
            const auto& t = oq.texels[k];
            const float* v = cubes[q]->at(t.t.f, t.t.i, t.t.j);
            vals.push_back({v[0], v[1], v[2]});
            vsum.push_back(channel_sum(v));
            rsum.push_back(channel_sum(oq.ref[k]));
        }
        const ref::LevelAccuracy a = ref::level_accuracy(oq.texels, vsum, rsum, oq.n, mean);
        const ref::ChannelAccuracy c = ref::level_accuracy_rgb(oq.texels, vals, oq.ref, oq.n, mean3);
        const ref::LevelAccuracy& wc = c.channel[c.worst_channel];
        char rough[16], maxc[24];
        std::snprintf(rough, sizeof(rough), oq.roughness < 0 ? "-" : "%.3f", oq.roughness);
        std::snprintf(maxc, sizeof(maxc), "%.2e %c", c.max_e, kChannel[c.worst_channel]);
        const size_t bins = oq.roughness < 0 ? 0 : r.samples_per_texel[q - (r.irradiance ? 1 : 0)];
        std::printf("%-12s %5d %6s %6zu | %9.2e %9.2e %+9.2e | %11s %9.2e %9.2e %+9.2e | %6zu  %d %d %d %c: %.4g, %.4g, %.1f\n",
                    oq.name.c_str(), oq.n, rough, oq.texels.size(), a.max_e, a.sa_rms, a.bias, maxc, c.p99_e, c.sa_rms,
                    c.bias, bins, wc.worst.f, wc.worst.i, wc.worst.j, kChannel[c.worst_channel], wc.worst_ref,
                    wc.worst_out, degrees(wc.worst, oq.n));
        if (worst > 0) {
            std::vector<size_t> idx(oq.texels.size());
            std::vector<double> err(oq.texels.size());
            std::vector<int> ch(oq.texels.size());
            for (size_t k = 0; k < idx.size(); ++k) {
                idx[k] = k;
                err[k] = ref::texel_error_rgb(vals[k], oq.ref[k], mean3, &ch[k]);
            }
            std::sort(idx.begin(), idx.end(), [&](size_t x, size_t y) { return err[x] > err[y]; });
            for (int k = 0; k < std::min<int>(worst, int(idx.size())); ++k) {
                const size_t i = idx[k];
                const auto& t = oq.texels[i].t;
                const ref::Rgb& rv = oq.ref[i];
                const ref::Rgb& ov = vals[i];
                std::printf("    e %.3e (%c)  %d %d %d  ref %.5g %.5g %.5g  out %.5g %.5g %.5g  (%+.3f %+.3f %+.3f %%)  "
                            "%.2f deg\n",
                            err[i], kChannel[ch[i]], t.f, t.i, t.j, rv[0], rv[1], rv[2], ov[0], ov[1], ov[2],
                            100 * (ov[0] / rv[0] - 1), 100 * (ov[1] / rv[1] - 1), 100 * (ov[2] / rv[2] - 1),
                            degrees(t, oq.n));
            }
        }
    }
    return 0;
}
