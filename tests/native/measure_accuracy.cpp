// iblbake_accuracy SOURCE [--face N] [--samples-per-level K] [--max-hot N] ...:
// bakes SOURCE with the default options (or those given) and measures every
// output against the exhaustive reference integrator (tests/native/reference.h)
// on up to K texels per level (all texels of small levels), printing one row
// per output. Not a test: a measuring tool for closing notes and benchmarks.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "iblbake/bake/bake.h"
#include "iblbake/io/image_io.h"
#include "iblbake/ibl/source.h"
#include "iblbake/math/cube.h"
#include "reference.h"

using namespace iblbake;

namespace {
struct Stats { double rmse, p99, max, mean; };
Stats stats(std::vector<double> e) {
    Stats s{0, 0, 0, 0};
    for (double x : e) { s.rmse += x * x; s.max = std::max(s.max, x); s.mean += x; }
    s.rmse = std::sqrt(s.rmse / e.size());
    s.mean /= e.size();
    std::sort(e.begin(), e.end());
    s.p99 = e[std::min(e.size() - 1, size_t(0.99 * e.size()))];
    return s;
}
double rel(const float* v, const ref::Rgb& r) {
    const double rs = r[0] + r[1] + r[2], vs = double(v[0]) + v[1] + v[2];
    return std::fabs(vs - rs) / std::max(rs, 1e-30);
}
}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: iblbake_accuracy SOURCE [--face N] [--per-level K] [--max-hot N] [--hot-threshold X] [--rings N] [--lod-bias X]\n");
        return 2;
    }
    BakeOptions o;
    int per_level = 400;
    for (int a = 2; a + 1 < argc; a += 2) {
        const std::string k = argv[a];
        const double v = std::atof(argv[a + 1]);
        if (k == "--face") o.face_size = int(v);
        else if (k == "--per-level") per_level = int(v);
        else if (k == "--max-hot") o.max_hot = int(v);
        else if (k == "--hot-threshold") o.hot_threshold = v;
        else if (k == "--rings") o.specular_quality.rings = int(v);
        else if (k == "--lod-bias") o.specular_quality.lod_bias = float(v);
        else if (k == "--base") o.specular_base_face = int(v);
        else if (k == "--eps") o.hierarchical.eps = v;
        else if (k == "--tile") o.hierarchical.tile = int(v);
        else if (k == "--max-phi") o.specular_quality.max_phi = int(v);
        else { std::fprintf(stderr, "unknown option %s\n", k.c_str()); return 2; }
    }
    o.lut = false;  // the LUT has its own reference tests
    io::LoadedImage li = io::read_image(argv[1]);
    Image src = li.image;
    sanitize(src);
    const auto t0 = std::chrono::steady_clock::now();
    const BakeResult r = compute_bake(li.image, o);
    const ref::TexelTable table = ref::texel_table(src);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("source %s (%dx%d), bake without LUT %.3f s, hot texels %zu (%.1f%% of power)\n", argv[1], src.width,
                src.height, secs, r.hot_texels, 100 * r.hot_power_fraction);
    std::printf("%-12s %5s %6s %5s %10s %10s %10s %10s\n", "output", "face", "rough", "n", "relRMSE", "p99", "max",
                "mean");
    {
        std::vector<double> e;
        for (const ref::CubeTexel& t : ref::sample_texels(r.irradiance->size, per_level, 1))
            e.push_back(rel(r.irradiance->at(t.f, t.i, t.j),
                            ref::irradiance(table, texel_direction(t.f, t.i, t.j, r.irradiance->size))));
        const Stats s = stats(e);
        std::printf("%-12s %5d %6s %5zu %10.2e %10.2e %10.2e %10.2e\n", "irradiance", r.irradiance->size, "-", e.size(),
                    s.rmse, s.p99, s.max, s.mean);
    }
    for (size_t m = 0; m < r.specular.size(); ++m) {
        const Cubemap& lvl = r.specular[m];
        std::vector<double> e;
        for (const ref::CubeTexel& t : ref::sample_texels(lvl.size, per_level, unsigned(m + 2)))
            e.push_back(rel(lvl.at(t.f, t.i, t.j),
                            ref::prefiltered(table, texel_direction(t.f, t.i, t.j, lvl.size), r.roughness[m])));
        const Stats s = stats(e);
        std::printf("%-12s %5d %6.3f %5zu %10.2e %10.2e %10.2e %10.2e  %s\n", ("specular_" + std::to_string(m)).c_str(),
                    lvl.size, r.roughness[m], e.size(), s.rmse, s.p99, s.max, s.mean, r.specular_methods[m].c_str());
    }
    return 0;
}
