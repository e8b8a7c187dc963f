// iblbake_bench: the benchmark's native half (bench/run.py drives it).
//   reference SRC OUT.csv IRR_FACE SPEC_FACE PER_LEVEL SMALL_FACE
//       exhaustive reference of SPEC's integral over the bilinear source
//       (tests/native/reference.h) at every irradiance texel and, per
//       specular level, every texel of levels of face <= SMALL_FACE, else
//       PER_LEVEL drawn at random plus every texel near a bright feature;
//       one CSV row per texel (`random` marks the uniform sample), and the
//       mean of L
//   seed-lut SIZE SAMPLES REPS OUT.f32
//   seed-irradiance SRC FACE DELTA REPS OUT.f32
//   seed-specular SRC FACE SAMPLES REPS OUT.f32
//       a seed baseline (bench/baselines.h), timed REPS times; prints the
//       median seconds and writes the result as raw float32 (levels
//       concatenated for specular)
//   seed-at REF.csv SRC irradiance|specular PARAM OUT.f32
//       the same baseline code (delta or samples = PARAM) at just the texels
//       of a reference CSV of that kind, in its row order, for the errors
//   dense-lut SIZE STRIDE N_THETA N_PHI OUT.csv
//       the independent dense estimator of A, B (karis) at every STRIDE-th
//       texel of a SIZE x SIZE LUT
//   sun W H OUT.exr
//       the pure-sun source: a 0.5 deg disc of 5e4 on a dim sky
//   redsun W H OUT.exr
//       issue 25's chromatic source: a red 0.5 deg disc of (5e4, 5e3, 0),
//       10 deg above the horizon, in a blue sky of (0.1, 0.3, 1) at the zenith
//   decode SRC
//       the file decoded alone, as the streamed bake decodes it (io::open_rows,
//       bands of preferred_band() rows into one buffer, libdeflate for zlib
//       as in the CLI) and nothing else: issue 28's "time to decode the file
//       alone"; time it from outside (bench/alternate.py)
//   decode-openexr SRC
//       the same bands of a scanline EXR of R, G, B halves decoded by
//       OpenEXR's own readPixels (its thread pool, zlib by libdeflate) and
//       made floats: what the reader did before it decoded ZIP blocks itself
//       (exr_zip.h), and what any program that reads the file with OpenEXR
//       takes
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfThreading.h>
#include <Imath/ImathBox.h>

#include "../tests/native/reference.h"
#include "baselines.h"
#include "iblbake/math/half.h"
#include "iblbake/ibl/source.h"
#include "iblbake/io/image_io.h"
#include "iblbake/io/row_reader.h"
#include "iblbake/math/cube.h"
#include "iblbake/util/parallel.h"

using namespace iblbake;

namespace {

// Median wall time of `reps` runs of fn.
double median_seconds(int reps, const std::function<void()>& fn) {
    std::vector<double> t;
    for (int r = 0; r < std::max(1, reps); ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        fn();
        t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(t.begin(), t.end());
    return t[t.size() / 2];
}

void write_f32(const std::string& path, FloatSpan v) {
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(v.data), std::streamsize(v.size * sizeof(float)));
    if (!f) throw std::runtime_error("cannot write " + path);
}

Image load_source(const std::string& path) {
    Image img = io::read_image(path).image;
    sanitize(img);
    return img;
}

int reference(const std::string& src_path, const std::string& out, int irr_face, int spec_face, int per_level,
              int small_face) {
    const Image src = load_source(src_path);
    const ref::TexelTable table = ref::texel_table(src);
    const std::vector<ref::BrightFeature> bright = ref::bright_features(src);
    struct Row { const char* kind; int level, face; ref::CubeTexel t; double rough; bool random; ref::Rgb v; };
    std::vector<Row> rows;
    // Irradiance: every texel (its goal holds everywhere, the nadir included).
    for (const ref::MeasureTexel& t : ref::measure_texels(irr_face, 1.0, {}, per_level, irr_face, 1))
        rows.push_back({"irradiance", 0, irr_face, t.t, 0.0, t.random, {}});
    int mips = 1;
    while ((spec_face >> mips) > 0) ++mips;
    for (int m = 0; m < mips; ++m) {
        const int n = std::max(1, spec_face >> m);
        const double rough = mips == 1 ? 0.0 : double(m) / (mips - 1);
        for (const ref::MeasureTexel& t : ref::measure_texels(n, rough, bright, per_level, small_face, unsigned(m + 2)))
            rows.push_back({"specular", m, n, t.t, rough, t.random, {}});
    }
    parallel_for(0, int(rows.size()), [&](int k) {
        Row& r = rows[k];
        const Vec3d n = texel_direction(r.t.f, r.t.i, r.t.j, r.face);
        r.v = r.kind[0] == 'i' ? ref::irradiance(table, n) : ref::prefiltered(table, n, r.rough);
    });
    FILE* f = std::fopen(out.c_str(), "w");
    if (!f) throw std::runtime_error("cannot write " + out);
    std::fprintf(f, "kind,level,face,f,i,j,roughness,random,r,g,b\n");
    const auto mean = ref::mean_radiance(table);  // of SPEC's bilinear L: every level's mean
    std::fprintf(f, "mean,-1,0,0,0,0,0,0,%.17g,%.17g,%.17g\n", mean[0], mean[1], mean[2]);
    for (const Row& r : rows)
        std::fprintf(f, "%s,%d,%d,%d,%d,%d,%.17g,%d,%.17g,%.17g,%.17g\n", r.kind, r.level, r.face, r.t.f, r.t.i, r.t.j,
                     r.rough, int(r.random), r.v[0], r.v[1], r.v[2]);
    std::fclose(f);
    return 0;
}

// The baseline at the texels of a reference CSV (rows of `kind`, in order).
int seed_at(const std::string& ref_csv, const std::string& src_path, const std::string& kind, double param,
            const std::string& out) {
    const Image src = load_source(src_path);
    struct Row { int face, f, i, j; double rough; };
    std::vector<Row> rows;
    std::ifstream in(ref_csv);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
        const size_t comma = line.find(',');
        if (line.substr(0, comma) != kind) continue;
        Row r{};
        int level = 0;
        if (std::sscanf(line.c_str() + comma + 1, "%d,%d,%d,%d,%d,%lf", &level, &r.face, &r.f, &r.i, &r.j, &r.rough) != 6)
            throw std::runtime_error("bad reference row: " + line);
        rows.push_back(r);
    }
    std::vector<float> v(rows.size() * 3);
    parallel_for(0, int(rows.size()), [&](int k) {
        const Row& r = rows[k];
        const Vec3d n = texel_direction(r.f, r.i, r.j, r.face);
        float* o = v.data() + size_t(k) * 3;
        if (kind == "irradiance") bench::seed_irradiance_at(src, Vec3(n), float(param), o);
        else if (r.rough == 0.0) latlong_bilinear(src, n, o);
        else bench::seed_prefilter_at(src, Vec3(n), float(r.rough), int(param), o);
    });
    write_f32(out, v);
    return 0;
}

int dense_lut(int size, int stride, int n_theta, int n_phi, const std::string& out) {
    std::vector<int> idx;
    for (int i = stride / 2; i < size; i += stride) idx.push_back(i);
    const int k = int(idx.size());
    std::vector<std::array<double, 2>> v(size_t(k) * k);
    parallel_for(0, k * k, [&](int p) {
        const int i = idx[p % k], j = idx[p / k];
        v[p] = ref::brdf_karis((i + 0.5) / size, (j + 0.5) / size, n_theta, n_phi);
    });
    FILE* f = std::fopen(out.c_str(), "w");
    if (!f) throw std::runtime_error("cannot write " + out);
    std::fprintf(f, "i,j,a,b\n");
    for (int p = 0; p < k * k; ++p) std::fprintf(f, "%d,%d,%.17g,%.17g\n", idx[p % k], idx[p / k], v[p][0], v[p][1]);
    std::fclose(f);
    return 0;
}

int decode(const std::string& path) {
    const std::unique_ptr<io::RowReader> reader = io::open_rows(path);
    if (!reader) throw std::runtime_error(path + " is read whole, not in bands");
    const int band = reader->preferred_band(), w = reader->width(), h = reader->height();
    std::vector<float> rows(size_t(w) * size_t(std::min(band, h)) * 3);
    double check = 0.0;
    for (int y = 0; y < h; y += band) {
        const int n = std::min(band, h - y);
        reader->read(y, n, rows.data());
        check += rows[size_t(n - 1) * size_t(w) * 3];
    }
    std::printf("%d x %d in bands of %d rows (checksum %g)\n", w, h, band, check);
    return 0;
}

int decode_openexr(const std::string& path) {
    Imf::setGlobalThreadCount(int(std::max(1u, std::thread::hardware_concurrency())));
    Imf::InputFile in(path.c_str(), 1);  // two line buffers in flight, as ExrRowReader asks (exr_file.cpp)
    const Imath::Box2i dw = in.header().dataWindow();
    const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1, band = 128;
    std::vector<float> rows(size_t(w) * band * 3);
    double check = 0.0;
    for (int y = 0; y < h; y += band) {
        const int n = std::min(band, h - y);
        // The halves in the upper half of the rows' floats, made floats in
        // place: ExrRowReader::read's way before 227d141.
        const size_t values = size_t(n) * w * 3;
        char* halves = reinterpret_cast<char*>(rows.data()) + values * sizeof(uint16_t);
        Imf::FrameBuffer fb;
        char* base = halves - (dw.min.x + ptrdiff_t(dw.min.y + y) * w) * 6;
        const char* names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; ++c) fb.insert(names[c], Imf::Slice(Imf::HALF, base + 2 * c, 6, size_t(w) * 6));
        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y + y, dw.min.y + y + n - 1);
        halves_to_floats(halves, rows.data(), values);
        check += rows[size_t(n - 1) * size_t(w) * 3];
    }
    std::printf("%d x %d in bands of %d rows by OpenEXR (checksum %g)\n", w, h, band, check);
    return 0;
}

int usage() {
    std::fprintf(stderr,
                 "usage: iblbake_bench reference SRC OUT.csv IRR_FACE SPEC_FACE PER_LEVEL SMALL_FACE\n"
                 "       iblbake_bench seed-lut SIZE SAMPLES REPS OUT.f32\n"
                 "       iblbake_bench seed-irradiance SRC FACE DELTA REPS OUT.f32\n"
                 "       iblbake_bench seed-specular SRC FACE SAMPLES REPS OUT.f32\n"
                 "       iblbake_bench seed-at REF.csv SRC irradiance|specular PARAM OUT.f32\n"
                 "       iblbake_bench dense-lut SIZE STRIDE N_THETA N_PHI OUT.csv\n"
                 "       iblbake_bench sun W H OUT.exr\n"
                 "       iblbake_bench redsun W H OUT.exr\n"
                 "       iblbake_bench decode SRC\n"
                 "       iblbake_bench decode-openexr SRC\n");
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    const std::vector<std::string> a(argv + 1, argv + argc);
    auto i = [&](size_t k) { return std::atoi(a.at(k).c_str()); };
    try {
        if (a.size() == 7 && a[0] == "reference") return reference(a[1], a[2], i(3), i(4), i(5), i(6));
        if (a.size() == 6 && a[0] == "seed-at") return seed_at(a[1], a[2], a[3], std::atof(a[4].c_str()), a[5]);
        if (a.size() == 6 && a[0] == "dense-lut") return dense_lut(i(1), i(2), i(3), i(4), a[5]);
        if (a.size() == 4 && a[0] == "sun") {
            const Image img = ref::sun_source(i(1), i(2), {0.55, 0.62, 0.56}, 0.25, 5e4f, 0.5f);
            io::write_exr(a[3], img, io::ExrPixel::Float);
            return 0;
        }
        if (a.size() == 4 && a[0] == "redsun") {
            const Image img = ref::red_sun_source(i(1), i(2), {-0.3, 0.94, 0.17}, 0.25, 5e4f, 1.0f);
            io::write_exr(a[3], img, io::ExrPixel::Float);
            return 0;
        }
        if (a.size() == 2 && a[0] == "decode") return decode(a[1]);
        if (a.size() == 2 && a[0] == "decode-openexr") return decode_openexr(a[1]);
        if (a.size() == 5 && a[0] == "seed-lut") {
            Image lut;
            const double s = median_seconds(i(3), [&] { lut = bench::seed_brdf_lut(i(1), i(2)); });
            write_f32(a[4], lut.pixels);
            std::printf("seconds %.6f\n", s);
            return 0;
        }
        if (a.size() == 6 && a[0] == "seed-irradiance") {
            const Image src = load_source(a[1]);
            Cubemap irr;
            const float delta = float(std::atof(a[3].c_str()));
            const double s = median_seconds(i(4), [&] { irr = bench::seed_irradiance(src, i(2), delta); });
            write_f32(a[5], irr.pixels);
            std::printf("seconds %.6f\n", s);
            return 0;
        }
        if (a.size() == 6 && a[0] == "seed-specular") {
            const Image src = load_source(a[1]);
            bench::SeedSpecular spec;
            const double s = median_seconds(i(4), [&] { spec = bench::seed_specular(src, i(2), i(3)); });
            std::vector<float> all;
            for (const Cubemap& c : spec.levels) all.insert(all.end(), c.pixels.begin(), c.pixels.end());
            write_f32(a[5], all);
            std::printf("seconds %.6f\n", s);
            return 0;
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "iblbake_bench: %s\n", e.what());
        return 1;
    }
    return usage();
}
