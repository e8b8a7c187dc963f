#include "iblbake/ibl/specular.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>

#include "iblbake/math/cube.h"
#include "iblbake/math/fast_math.h"
#include "iblbake/math/ggx.h"
#include "iblbake/math/quadrature.h"
#include "iblbake/util/parallel.h"
#include "specular_kernel.h"

namespace iblbake {

std::vector<KernelSample> make_kernel_samples(double roughness, const SpecularQuality& q, int base_face) {
    const double alpha = roughness * roughness;
    const double upper = 1.0 / (1.0 + alpha * alpha);  // n.w = 0 at this u
    const QuadratureRule rule = gauss_legendre(std::max(1, q.rings), 0.0, upper);
    // Level-0 texel solid angle at a face centre is (2 / base)^2.
    const double lod_texel = std::log2(2.0 / base_face);
    std::vector<KernelSample> samples;
    double weight_sum = 0.0;
    for (size_t i = 0; i < rule.nodes.size(); ++i) {
        const double u = rule.nodes[i];
        const double cos2 = ggx::sample_cos2(alpha, u), sin2 = ggx::sample_sin2(alpha, u);
        const double c = cos2 - sin2;                       // n.w = cos(2 theta_h)
        const double sin_w = 2.0 * std::sqrt(cos2 * sin2);  // sin(2 theta_h)
        // Cell sizes: dh = du dphi / (2 pi D cos_h), dw = 4 cos_h dh, so the
        // ring's solid angle is 4 g_i / D.
        const double ring = 4.0 * rule.weights[i] / ggx::D(alpha, cos2, sin2);
        const double circumference = 2.0 * kPi * sin_w;
        const int nphi = std::clamp(int(std::lround(circumference * circumference / ring)), q.min_phi, q.max_phi);
        const double cell = ring / nphi;
        const double lod = 0.5 * std::log2(cell) - lod_texel + q.lod_bias;
        const double offset = std::fmod(0.6180339887498949 * double(i), 1.0);  // rotate rings apart
        for (int k = 0; k < nphi; ++k) {
            const double phi = 2.0 * kPi * (k + offset) / nphi;
            KernelSample s;
            s.t = float(sin_w * std::cos(phi));
            s.b = float(sin_w * std::sin(phi));
            s.n = float(c);
            s.weight = float(rule.weights[i] * c / nphi);
            s.lod_base = float(lod);
            weight_sum += s.weight;
            samples.push_back(s);
        }
    }
    for (auto& s : samples) s.weight = float(s.weight / weight_sum);
    return samples;
}

namespace {

// Texels of one face row at lat-long coordinates (fx, fy) (pixel units,
// fx within one period of [0, w)): latlong_bilinear's arithmetic, the
// source's texel (x, y) at at(x, y).
template <typename At>
inline void bilinear_row(At at, int w, int h, const double* fx, const double* fy, int n, float* out) {
    constexpr int kAhead = 8;  // the rows of the lookup kAhead on, asked for now (the source outgrows the caches)
    for (int i = 0; i < n; ++i) {
        if (i + kAhead < n) {
            const int xa = std::clamp(int(fx[i + kAhead]), 0, w - 1), ya = std::clamp(int(fy[i + kAhead]), 0, h - 1);
            __builtin_prefetch(at(xa, ya));
            __builtin_prefetch(at(xa, std::min(ya + 1, h - 1)));
        }
        const double x0f = std::floor(fx[i]), y0f = std::floor(fy[i]);
        const double tx = fx[i] - x0f, ty = fy[i] - y0f;
        int x0 = int(x0f);  // within one period of [0, w): wrapped without a division
        if (x0 >= w) x0 -= w;
        else if (x0 < 0) x0 += w;
        if (x0 < 0 || x0 >= w) x0 = ((x0 % w) + w) % w;
        const int x1 = x0 + 1 == w ? 0 : x0 + 1;
        const int y0 = std::clamp(int(y0f), 0, h - 1), y1 = std::clamp(int(y0f) + 1, 0, h - 1);
        const float *pa = at(x0, y0), *pb = at(x1, y0), *pc = at(x0, y1), *pd = at(x1, y1);
        float* o = out + size_t(i) * 3;
        for (int k = 0; k < 3; ++k) {
            const double top = pa[k] + (pb[k] - pa[k]) * tx;
            const double bottom = pc[k] + (pd[k] - pc[k]) * tx;
            o[k] = float(top + (bottom - top) * ty);
        }
    }
}

// A contiguous source (no row table), the common case: plain offsets, built
// for AVX-512, AVX2 and baseline x86-64 without fused multiply-add (the same
// bits on every CPU; rounding by instruction instead of the baseline's floor
// sequence).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default"), optimize("fp-contract=off")))
#endif
void mirror_lookups_contiguous(const float* data, int w, int h, const double* fx, const double* fy, int n,
                               float* out) {
    const ptrdiff_t stride = ptrdiff_t(w) * 3;
    bilinear_row([data, stride](int x, int y) { return data + y * stride + ptrdiff_t(x) * 3; }, w, h, fx, fy, n, out);
}

void mirror_lookups(ImageView latlong, const double* fx, const double* fy, int n, float* out) {
    if (!latlong.rows) return mirror_lookups_contiguous(latlong.data, latlong.width, latlong.height, fx, fy, n, out);
    bilinear_row([&latlong](int x, int y) { return latlong.at(x, y); }, latlong.width, latlong.height, fx, fy, n, out);
}

}  // namespace

void specular_mirror(Cubemap& dst, ImageView latlong) {
    const int n = dst.size, w = latlong.width, h = latlong.height;
    const kernel::MirrorRowFn coords = kernel::mirror_row_fn();
    auto frame_of = [](int f, double* frame) {
        const FaceFrame& fr = kFaceFrames[f];
        const double v[9] = {fr.ma.x, fr.ma.y, fr.ma.z, fr.s.x, fr.s.y, fr.s.z, fr.t.x, fr.t.y, fr.t.z};
        std::copy(v, v + 9, frame);
    };
    // The four side faces (+-X, +-Z: t is -Y on each) share their rows'
    // latitudes: a texel's direction is (horizontal, -b) with a horizontal
    // part of length sqrt(1 + a^2) on every one of them, so the face-row's
    // fy (one atan2 per texel) is computed once for four faces, and fx
    // depends on the column alone (once per face). The top and bottom
    // faces are computed row by row. Every coordinate is kernel::mirror_row's.
    constexpr int kSide[4] = {0, 1, 4, 5};
    std::vector<double> side_fx(size_t(4) * n), scratch(n);
    for (int s = 0; s < 4; ++s) {
        double frame[9];
        frame_of(kSide[s], frame);
        coords(frame, 0.0, n, w, h, side_fx.data() + size_t(s) * n, scratch.data());
    }
    // Tasks: n side rows (four faces each), then the top and bottom faces' 2n rows.
    parallel_for(0, 3 * n, [&](int task) {
        thread_local std::vector<double> fx, fy;
        fx.resize(n);
        fy.resize(n);
        if (task < n) {
            const int j = task;
            double frame[9];
            frame_of(0, frame);
            coords(frame, 2.0 * (j + 0.5) / n - 1.0, n, w, h, fx.data(), fy.data());
            for (int s = 0; s < 4; ++s)
                mirror_lookups(latlong, side_fx.data() + size_t(s) * n, fy.data(), n, dst.at(kSide[s], 0, j));
            return;
        }
        const int row = task - n, f = 2 + row / n, j = row % n;  // +Y, -Y
        double frame[9];
        frame_of(f, frame);
        coords(frame, 2.0 * (j + 0.5) / n - 1.0, n, w, h, fx.data(), fy.data());
        mirror_lookups(latlong, fx.data(), fy.data(), n, dst.at(f, 0, j));
    });
}

namespace {
// The two source rows a lookup at fy reads (bilinear_row's clamping).
inline void rows_of(double fy, int h, int& lo, int& hi) {
    const int y0 = int(std::floor(fy));
    lo = std::clamp(y0, 0, h - 1);
    hi = std::clamp(y0 + 1, 0, h - 1);
}
void frame_of_face(int f, double* frame) {
    const FaceFrame& fr = kFaceFrames[f];
    const double v[9] = {fr.ma.x, fr.ma.y, fr.ma.z, fr.s.x, fr.s.y, fr.s.z, fr.t.x, fr.t.y, fr.t.z};
    std::copy(v, v + 9, frame);
}
constexpr int kSideFaces[4] = {0, 1, 4, 5};
}  // namespace

MirrorStream::MirrorStream(Cubemap& dst, int src_w, int src_h)
    : dst_(dst), n_(dst.size), w_(src_w), h_(src_h) {
    const int n = n_;
    const kernel::MirrorRowFn coords = kernel::mirror_row_fn();
    side_fx_.resize(size_t(4) * n);
    std::vector<double> scratch(n);
    for (int s = 0; s < 4; ++s) {
        double frame[9];
        frame_of_face(kSideFaces[s], frame);
        coords(frame, 0.0, n, w_, h_, side_fx_.data() + size_t(s) * n, scratch.data());
    }
    side_fy_.resize(size_t(n) * n);
    polar_fx_.resize(size_t(2) * n * n);
    polar_fy_.resize(size_t(2) * n * n);
    parallel_for(0, 3 * n, [&](int task) {
        std::vector<double> fx(n);
        double frame[9];
        if (task < n) {
            frame_of_face(0, frame);
            coords(frame, 2.0 * (task + 0.5) / n - 1.0, n, w_, h_, fx.data(), side_fy_.data() + size_t(task) * n);
            return;
        }
        const int row = task - n, f = 2 + row / n, j = row % n;
        frame_of_face(f, frame);
        const size_t at = (size_t(f - 2) * n + j) * n;
        coords(frame, 2.0 * (j + 0.5) / n - 1.0, n, w_, h_, polar_fx_.data() + at, polar_fy_.data() + at);
    });
    // Counting sorts by last row (stable: the order within a row is the texels').
    auto bucket = [h = h_](const std::vector<double>& fy, std::vector<uint32_t>& order, std::vector<uint32_t>& start) {
        start.assign(size_t(h) + 1, 0);
        std::vector<int> hi_of(fy.size());
        for (size_t k = 0; k < fy.size(); ++k) {
            int lo, hi;
            rows_of(fy[k], h, lo, hi);
            hi_of[k] = hi;
            ++start[size_t(hi) + 1];
        }
        for (int y = 0; y < h; ++y) start[size_t(y) + 1] += start[size_t(y)];
        std::vector<uint32_t> next(start.begin(), start.end() - 1);
        order.resize(fy.size());
        for (size_t k = 0; k < fy.size(); ++k) order[next[size_t(hi_of[k])]++] = uint32_t(k);
    };
    bucket(side_fy_, side_order_, side_start_);
    bucket(polar_fy_, polar_order_, polar_start_);
    pending_ = size_t(6) * n * n;
}

void MirrorStream::add_rows(ImageView img, int y0, int y1) {
    const int n = n_, w = w_, h = h_;
    auto at = [&img](int x, int y) { return img.at(x, y); };
    if (y0 > last_row_ + 1) throw std::logic_error("MirrorStream: bands must come in order and overlap");
    y1 = std::min(y1, h - 1);
    if (y1 <= last_row_) return;
    // The texels whose last row is new in this band (their first row, one
    // less or the same, is in it too).
    const uint32_t s0 = side_start_[size_t(last_row_ + 1)], s1 = side_start_[size_t(y1) + 1];
    const uint32_t p0 = polar_start_[size_t(last_row_ + 1)], p1 = polar_start_[size_t(y1) + 1];
    const int side_chunks = int(std::min<uint32_t>(256, s1 - s0)), polar_chunks = int(std::min<uint32_t>(256, p1 - p0));
    parallel_for(0, side_chunks + polar_chunks, [&](int c) {
        const bool side = c < side_chunks;
        const int chunks = side ? side_chunks : polar_chunks, cc = side ? c : c - side_chunks;
        const uint32_t first = side ? s0 : p0, last = side ? s1 : p1;
        const uint32_t a = first + uint32_t(uint64_t(last - first) * uint64_t(cc) / uint64_t(chunks));
        const uint32_t b = first + uint32_t(uint64_t(last - first) * uint64_t(cc + 1) / uint64_t(chunks));
        for (uint32_t q = a; q < b; ++q) {
            if (side) {
                const uint32_t k = side_order_[q];
                const int j = int(k / uint32_t(n)), i = int(k % uint32_t(n));
                for (int s = 0; s < 4; ++s)
                    bilinear_row(at, w, h, side_fx_.data() + size_t(s) * n + i, &side_fy_[k], 1,
                                 dst_.at(kSideFaces[s], i, j));
            } else {
                const uint32_t k = polar_order_[q];
                const int f = 2 + int(k / (uint32_t(n) * uint32_t(n))), j = int(k / uint32_t(n) % uint32_t(n)),
                          i = int(k % uint32_t(n));
                bilinear_row(at, w, h, &polar_fx_[k], &polar_fy_[k], 1, dst_.at(f, i, j));
            }
        }
    });
    pending_ -= size_t(s1 - s0) * 4 + size_t(p1 - p0);
    last_row_ = y1;
}

namespace {

// Exact kernel sum of the hot points for one direction, divided by Z(alpha).
void hot_term(const std::vector<RadiancePoint>& hot, const Vec3& n, float alpha, float inv_z, float out[3]) {
    const float a2 = alpha * alpha, norm = 4.0f * a2 / float(kPi);
    float acc[3] = {0, 0, 0};
    for (const RadiancePoint& p : hot) {
        const float dx = n.x - p.dir[0], dy = n.y - p.dir[1], dz = n.z - p.dir[2];
        const float omc = 0.5f * (dx * dx + dy * dy + dz * dz);  // 1 - n.w without cancellation
        const float k = norm * ggx::prefilter_kernel_shape(a2, omc);
        for (int ch = 0; ch < 3; ++ch) acc[ch] += k * p.power[ch];
    }
    for (int ch = 0; ch < 3; ++ch) out[ch] = acc[ch] * inv_z;
}

}  // namespace

size_t specular_prefilter(Cubemap& dst, const CubePyramid& rest, const std::vector<RadiancePoint>& hot,
                        double roughness, const SpecularQuality& q) {
    const std::vector<KernelSample> samples = make_kernel_samples(roughness, q, rest.base_size());
    const double alpha = roughness * roughness;
    const float inv_z = float(1.0 / ggx::prefilter_normalizer(alpha));
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) {
            const Vec3 nn(texel_direction(f, i, j, n));
            Vec3 t, b;
            orthonormal_basis(nn, t, b);
            float acc[3] = {0, 0, 0};
            for (const KernelSample& s : samples) {
                const Vec3 w = t * s.t + b * s.b + nn * s.n;
                // Texel solid angle grows as |w_major|^-3 toward face centres.
                const float ma = std::max(std::fabs(w.x), std::max(std::fabs(w.y), std::fabs(w.z)));
                const float lod = s.lod_base - 1.5f * std::log2(ma);
                float v[3];
                rest.trilinear(w, lod, v);
                for (int k = 0; k < 3; ++k) acc[k] += s.weight * v[k];
            }
            float h[3] = {0, 0, 0};
            if (!hot.empty()) hot_term(hot, nn, float(alpha), inv_z, h);
            float* o = dst.at(f, i, j);
            for (int k = 0; k < 3; ++k) o[k] = acc[k] + h[k];
        }
    });
    return samples.size();
}

namespace {

using kernel::kFields;
using kernel::kLanes;

// The kernel's instruction set: the best the CPU has, unless IBLBAKE_ISA
// (baseline, avx2, avx512) asks for less; chosen once per process.
enum class Isa { Baseline = 0, Avx2 = 1, Avx512 = 2 };
constexpr const char* kIsaNames[] = {"baseline", "avx2", "avx512"};

Isa best_isa() {
#if defined(__x86_64__) && defined(IBLBAKE_KERNEL_X86)
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) return Isa::Avx512;
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return Isa::Avx2;
#endif
    return Isa::Baseline;
}

int isa_from_name(const char* name) {
    for (int k = 0; k < 3; ++k)
        if (std::strcmp(name, kIsaNames[k]) == 0) return k;
    return -1;
}

Isa initial_isa() {
    const Isa best = best_isa();
    const char* env = std::getenv("IBLBAKE_ISA");
    if (!env || !*env) return best;
    const int asked = isa_from_name(env);
    if (asked < 0) {
        std::fprintf(stderr, "iblbake: IBLBAKE_ISA=%s is not baseline, avx2 or avx512; using %s\n", env,
                     kIsaNames[int(best)]);
        return best;
    }
    return Isa(std::min(asked, int(best)));  // never more than the CPU has
}

std::atomic<int>& isa_choice() {
    static std::atomic<int> choice{int(initial_isa())};
    return choice;
}

// The build of a kernel for the chosen instruction set (its three builds:
// name_baseline, name_avx2, name_avx512; the last two on x86-64 alone).
template <typename Fn>
Fn by_isa(Fn baseline, Fn avx2, Fn avx512) {
    switch (Isa(isa_choice().load(std::memory_order_relaxed))) {
        case Isa::Avx512: return avx512;
        case Isa::Avx2: return avx2;
        default: return baseline;
    }
}
#if defined(IBLBAKE_KERNEL_X86)
#define IBLBAKE_BY_ISA(name) by_isa(kernel::name##_baseline, kernel::name##_avx2, kernel::name##_avx512)
#else
#define IBLBAKE_BY_ISA(name) kernel::name##_baseline
#endif

static_assert(offsetof(BinNode, px) == kernel::kNodePx * sizeof(float) &&
                  offsetof(BinNode, py) == kernel::kNodePy * sizeof(float) &&
                  offsetof(BinNode, pz) == kernel::kNodePz * sizeof(float) &&
                  offsetof(BinNode, radius) == kernel::kNodeRadius * sizeof(float) &&
                  offsetof(BinNode, g) == kernel::kG * sizeof(float) &&
                  offsetof(BinNode, power) == kernel::kP0 * sizeof(float) &&
                  offsetof(BinNode, cov) == kernel::kCxx * sizeof(float) &&
                  offsetof(BinNode, chroma) == kernel::kNodeChroma * sizeof(float) &&
                  offsetof(BinNode, chroma_scores) == kernel::kNodeScores * sizeof(float) &&
                  sizeof(BinNode) == kernel::kNodeFloats * sizeof(float),
              "the traversal and node-fields kernels read BinNode's fields at these offsets");

kernel::SumsFn kernel_fn() {
    return IBLBAKE_BY_ISA(sums);
}

}  // namespace

kernel::MirrorRowFn kernel::mirror_row_fn() {
    return IBLBAKE_BY_ISA(mirror_row);
}

kernel::IrrHorizonFn kernel::irr_horizon_fn() {
    return IBLBAKE_BY_ISA(irr_horizon);
}

std::atomic<bool>& traversal_lanes_on() {
    static std::atomic<bool> on{true};
    return on;
}

kernel::TraverseLevelFn kernel::traverse_level_fn() {
    if (!traversal_lanes_on().load(std::memory_order_relaxed)) return nullptr;
    switch (Isa(isa_choice().load(std::memory_order_relaxed))) {
#if defined(IBLBAKE_KERNEL_X86)
        case Isa::Avx512: return kernel::traverse_level_avx512;
#endif
        default: return nullptr;
    }
}

kernel::NodeFieldsFn kernel::node_fields_fn() {
#if defined(IBLBAKE_KERNEL_X86)
    if (kernel::traverse_level_fn() == kernel::traverse_level_avx512) return kernel::node_fields_avx512;
#endif
    return nullptr;
}

kernel::IrrSumFn kernel::irr_sum_fn() {
    return IBLBAKE_BY_ISA(irr_sum);
}

kernel::RowPiecesFn kernel::row_pieces_fn() {
    return IBLBAKE_BY_ISA(row_pieces);
}

kernel::Sh9Band2Fn kernel::sh9_band2_fn() {
    return IBLBAKE_BY_ISA(sh9_band2);
}

const char* specular_kernel_isa() { return kIsaNames[isa_choice().load()]; }

bool set_specular_traversal_lanes(bool on) {
    traversal_lanes_on().store(on);
    return on && kernel::traverse_level_fn() != nullptr;
}

bool set_specular_kernel_isa(const std::string& isa) {
    const int best = int(best_isa());
    const int asked = isa.empty() ? best : isa_from_name(isa.c_str());
    if (asked < 0) throw std::invalid_argument("kernel instruction set must be baseline, avx2 or avx512");
    if (asked > best) return false;
    isa_choice().store(asked);
    return true;
}

double hierarchical_level_eps(const HierarchicalQuality& q, int face) {
    return q.eps * std::clamp(std::sqrt(face / 64.0), 0.5, 1.0);
}

double hierarchical_horizon_radius(double roughness, int face, const HierarchicalQuality& q) {
    const double alpha = roughness * roughness, a2 = alpha * alpha;
    const double d45 = 4.0 * a2 / (kPi * (1.0 + a2) * (1.0 + a2));
    return std::min(kPi, hierarchical_level_eps(q, face) * q.horizon / std::sqrt(d45 / ggx::prefilter_normalizer(alpha)));
}

namespace {

// A tile of output texels: its texels' directions, centre and angular radius.
struct Tile {
    int face, i0, j0, i1, j1;
    std::vector<Vec3> dirs;
    Vec3 c;
    float rho;
};
Tile make_tile(int tile, int n, int T) {
    const int tiles_per_row = (n + T - 1) / T;
    Tile t;
    t.face = tile / (tiles_per_row * tiles_per_row);
    const int ty = (tile / tiles_per_row) % tiles_per_row, tx = tile % tiles_per_row;
    t.i0 = tx * T;
    t.j0 = ty * T;
    t.i1 = std::min(n, t.i0 + T);
    t.j1 = std::min(n, t.j0 + T);
    Vec3d sum{0, 0, 0};
    for (int j = t.j0; j < t.j1; ++j)
        for (int i = t.i0; i < t.i1; ++i) {
            const Vec3d d = texel_direction(t.face, i, j, n);
            t.dirs.emplace_back(d);
            sum += d;
        }
    t.c = Vec3(normalize(sum));
    float min_cos = 1.0f;
    for (const Vec3& d : t.dirs) min_cos = std::min(min_cos, dot(t.c, d));
    t.rho = std::acos(std::clamp(min_cos, -1.0f, 1.0f)) + 1e-6f;
    return t;
}

// Traverse the tree for a tile, one level at a time from the coarsest:
// accept a bin whole when it is small against the kernel's length scale at
// its least distance from the tile (and, when it may straddle a texel's
// horizon, no larger than horizon_radius), else visit its four children
// next. The accepted bins' fields go into acc, structure-of-arrays, padded
// to whole lanes with bins of no power; those of varying colour into
// chromatic, their places in acc into chroma_at and their rows for
// chroma_pass into tinted (kernel::Tinted). Returns the number accepted.
size_t gather_bins(const BinTree& tree, const Tile& t, float scale, float eps, float horizon_radius,
                   std::vector<float> (&acc)[kFields], std::vector<const BinNode*>& chromatic,
                   std::vector<uint32_t>& chroma_at, std::vector<float> (&tinted)[kernel::kTinted]) {
    thread_local std::vector<uint32_t> cur, next;
    thread_local std::vector<const BinNode*> accepted;
    cur.clear();
    accepted.clear();
    const Vec3& c = t.c;
    const float rho = t.rho;
    const int top = int(tree.levels.size()) - 1;
    for (int b = 0; b < tree.levels[top].w * tree.levels[top].h; ++b) cur.push_back(uint32_t(b));
    // Branch-free: every node's decision is computed, then its pointer (or
    // its four children) written unconditionally and the count advanced by
    // the decision. The same decisions in the same order as a loop that
    // branched on them (so the same sums to the bit), without the branches
    // that the data made unpredictable (they were most of this loop's time).
    const kernel::TraverseLevelFn lanes = kernel::traverse_level_fn();
    for (int lvl = top; lvl >= 0 && !cur.empty(); --lvl) {
        const BinLevel& L = tree.levels[lvl];
        const BinNode* nodes = L.nodes.data();
        const uint32_t w = uint32_t(L.w), shift = uint32_t(__builtin_ctz(w)), w2 = 2 * w;  // w: a power of two
        // Node b's four children at the next finer level, into out[0..4).
        auto children = [shift, w, w2](uint32_t b, uint32_t* out) {
            const uint32_t y = b >> shift, x = b & (w - 1);
            const uint32_t c0 = 2 * y * w2 + 2 * x;
            out[0] = c0, out[1] = c0 + 1, out[2] = c0 + w2, out[3] = c0 + w2 + 1;
        };
        if (lanes) {
            // The same decisions in lanes (kernel::traverse_level_fn): the
            // accepted and the split nodes by index, in order; then the
            // pointers and the split nodes' children, as below.
            thread_local std::vector<uint32_t> took, split;
            const size_t n = cur.size();
            took.resize(n);
            split.resize(n);
            size_t nt = 0, ns = 0;
            const float cc[3] = {c.x, c.y, c.z};
            lanes(reinterpret_cast<const float*>(nodes), cur.data(), n, lvl == 0, cc, rho, scale, eps, horizon_radius,
                  took.data(), &nt, split.data(), &ns);
            const size_t acc0 = accepted.size();
            accepted.resize(acc0 + nt);
            for (size_t k = 0; k < nt; ++k) accepted[acc0 + k] = nodes + took[k];
            next.resize(4 * ns);
            for (size_t k = 0; k < ns; ++k) children(split[k], next.data() + 4 * k);
            std::swap(cur, next);
            continue;
        }
        const size_t n = cur.size(), acc0 = accepted.size();
        accepted.resize(acc0 + n);
        next.resize(lvl == 0 ? 0 : 4 * n);
        size_t na = acc0, nn = 0;
        for (size_t k = 0; k < n; ++k) {
            const uint32_t b = cur[k];
            const BinNode& nd = nodes[b];
            const float beta = nd.radius;  // < 0: no radiance
            const float d = fast_acos(c.x * nd.px + c.y * nd.py + c.z * nd.pz);
            const float reach = d - beta - rho;
            // Not empty, and not behind every texel's horizon.
            const bool live = (beta >= 0.0f) & (reach < 0.5f * float(kPi));
            const float dmin = std::max(0.0f, reach);
            const bool near_horizon = std::fabs(d - 0.5f * float(kPi)) <= beta + rho;
            const bool small = (beta <= eps * std::max(scale, dmin)) & (!near_horizon | (beta <= horizon_radius));
            const bool take = live & ((lvl == 0) | small);
            accepted[na] = &nd;
            na += take;
            if (lvl > 0) {
                children(b, next.data() + nn);
                nn += 4 * size_t(live & !take);
            }
        }
        accepted.resize(na);
        next.resize(nn);
        std::swap(cur, next);
    }
    const size_t count = accepted.size();
    const size_t padded = (count + kLanes - 1) / kLanes * kLanes;
    for (auto& a : acc) a.resize(padded);
    // The bins of varying colour among them (chroma_pass), branch-free.
    chromatic.resize(count + 1);
    chroma_at.resize(count + 1);
    float* tq[kernel::kTinted];
    for (int r = 0; r < kernel::kTinted; ++r) {
        tinted[r].resize(count + 1);
        tq[r] = tinted[r].data();
    }
    size_t nc = 0;
    if (const kernel::NodeFieldsFn fields = kernel::node_fields_fn()) {
        // The same in lanes, by a transpose of 16 nodes at a time.
        float* out[kFields];
        for (int k = 0; k < kFields; ++k) out[k] = acc[k].data();
        fields(reinterpret_cast<const float* const*>(accepted.data()), count, out, chroma_at.data(), tq, &nc);
        for (size_t k = 0; k < nc; ++k) chromatic[k] = accepted[chroma_at[k]];
    } else {
        for (size_t i = 0; i < count; ++i) {
            const BinNode& nd = *accepted[i];
            chromatic[nc] = &nd;
            chroma_at[nc] = uint32_t(i);
            nc += nd.chroma != 0;
            acc[kernel::kPx][i] = nd.px, acc[kernel::kPy][i] = nd.py, acc[kernel::kPz][i] = nd.pz;
            acc[kernel::kG][i] = nd.g;
            for (int ch = 0; ch < 3; ++ch) acc[kernel::kP0 + ch][i] = nd.power[ch];
            for (int k = 0; k < 6; ++k) acc[kernel::kCxx + k][i] = nd.cov[k];
        }
        // The tinted ones' rows, from those alone (most bins of most skies
        // have none).
        for (size_t k = 0; k < nc; ++k) {
            const BinNode& nd = *chromatic[k];
            tq[kernel::kTx][k] = nd.px, tq[kernel::kTy][k] = nd.py, tq[kernel::kTz][k] = nd.pz;
            tq[kernel::kTBeta][k] = nd.radius;
            for (int c = 0; c < 3; ++c) tq[kernel::kTScore0 + c][k] = nd.chroma_score(c), tq[kernel::kTP0 + c][k] = nd.power[c];
        }
    }
    for (auto& a : acc) std::fill(a.begin() + count, a.end(), 0.0f);
    chromatic.resize(nc);
    chroma_at.resize(nc);
    for (auto& r : tinted) r.resize(nc);
    return count;
}

// The sums over the bins in acc (padded to whole lanes here) at each texel
// of the tile, texels_per_call(K) texels a call in row-major order:
// out(i, j, num) with num[lobe][channel].
template <typename Out>
void sum_tile(const Tile& t, std::vector<float> (&acc)[kFields], int K, const float* a2, kernel::SumsFn sums,
              Out out) {
    const size_t padded = (acc[0].size() + kLanes - 1) / kLanes * kLanes;
    for (auto& a : acc) a.resize(padded, 0.0f);
    const float* fields[kFields];
    for (int k = 0; k < kFields; ++k) fields[k] = acc[k].data();
    const int w = t.i1 - t.i0, texels = w * (t.j1 - t.j0), per_call = kernel::texels_per_call(K);
    for (int k0 = 0; k0 < texels; k0 += per_call) {
        const int m = std::min(per_call, texels - k0);
        float dirs[3 * kernel::kMaxLobes];
        for (int q = 0; q < m; ++q) {
            const Vec3& d = t.dirs[size_t(k0 + q)];
            dirs[3 * q] = d.x, dirs[3 * q + 1] = d.y, dirs[3 * q + 2] = d.z;
        }
        double num[kernel::kMaxLobes][kernel::kMaxLobes][3];
        sums(fields, padded, K, a2, dirs, m, num);
        for (int q = 0; q < m; ++q) out(t.i0 + (k0 + q) % w, t.j0 + (k0 + q) / w, num[q]);
    }
}

// The estimates of chroma_pass for n bins of varying colour seen from a
// tile, in lanes. Per lobe g, the kernel's variation across bin b,
// dk = inv_z (k(theta - beta) - k(theta + beta)), theta = max(0, d - rho)
// the bin's distance to the tile's nearest texel (d from the tile's centre
// c), beta its radius, k(c) = c / t^2 (t = (1 - c)(1 - a2) + 2 a2) for
// c > 0, else 0 (angles by their cosines and sines, those of beta by
// series in beta / 2: under 3e-5 off up to beta = pi); per channel the
// estimate e = score_c P_c dk, into est[(g 3 + c) n + b], and its largest
// ratio to the limits over the lobes into key[c n + b]; the estimates
// summed per lobe and channel in 16 fixed lanes into total. in: the bins'
// rows (kernel::Tinted: p, beta, score (3), power (3)), n each. Built per
// instruction set without fused multiply-add and with the lanes fixed: the
// same bits, so the same bins chosen, on every CPU.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default"), optimize("fp-contract=off")))
#endif
void chroma_estimates(const float* const* in, size_t n, float cx, float cy, float cz, float cr, float sr, int K,
                      const float* a2, const float* inv_z, const float (*inv_limit)[3], float* est, float* key,
                      double (*total)[3]) {
    const float *px = in[kernel::kTx], *py = in[kernel::kTy], *pz = in[kernel::kTz], *beta = in[kernel::kTBeta];
    for (size_t q = 0; q < 3 * n; ++q) key[q] = 0.0f;
    thread_local std::vector<float> dkv, cbv, sbv;
    dkv.resize(n), cbv.resize(n), sbv.resize(n);
    float *dk = dkv.data(), *cb = cbv.data(), *sb = sbv.data();
    for (size_t b = 0; b < n; ++b) {
        // x = beta / 2 <= pi / 2: sin x and cos x by their series to x^9 and
        // x^8, then cos beta = 1 - 2 sin^2 x, sin beta = 2 sin x cos x.
        const float x = 0.5f * beta[b], x2 = x * x;
        const float sx = x * (1.0f - x2 / 6.0f * (1.0f - x2 / 20.0f * (1.0f - x2 / 42.0f * (1.0f - x2 / 72.0f))));
        const float cx2 = 1.0f - x2 / 2.0f * (1.0f - x2 / 12.0f * (1.0f - x2 / 30.0f * (1.0f - x2 / 56.0f)));
        cb[b] = 1.0f - 2.0f * sx * sx;
        sb[b] = 2.0f * sx * cx2;
    }
    for (int g = 0; g < K; ++g) {
        const float s = 1.0f - a2[g], t2 = 2.0f * a2[g], iz = inv_z[g];
        for (size_t b = 0; b < n; ++b) {
            const float cd = std::min(1.0f, cx * px[b] + cy * py[b] + cz * pz[b]);
            const float sd = std::sqrt(std::max(0.0f, 1.0f - cd * cd));
            const bool inside = cd >= cr;  // d <= rho: theta = 0
            const float ct = inside ? 1.0f : cd * cr + sd * sr, st = inside ? 0.0f : sd * cr - cd * sr;
            const float cn = ct >= cb[b] ? 1.0f : ct * cb[b] + st * sb[b];  // theta <= beta: 0
            const float cf = ct * cb[b] - st * sb[b];
            const float tn = (1.0f - cn) * s + t2, tf = (1.0f - cf) * s + t2;
            const float kn = cn > 0.0f ? cn / (tn * tn) : 0.0f, kf = cf > 0.0f ? cf / (tf * tf) : 0.0f;
            dk[b] = (kn - kf) * iz;
        }
        for (int c = 0; c < 3; ++c) {
            const float il = inv_limit[g][c];
            const float *sc = in[kernel::kTScore0 + c], *pc = in[kernel::kTP0 + c];
            float* e = est + (size_t(g) * 3 + c) * n;
            float* k = key + size_t(c) * n;
            float lanes[16] = {};
            size_t b = 0;
            for (; b + 16 <= n; b += 16)
                for (int l = 0; l < 16; ++l) {
                    const float v = sc[b + l] * pc[b + l] * dk[b + l];
                    e[b + l] = v;
                    lanes[l] += v;
                    k[b + l] = std::max(k[b + l], v * il);
                }
            for (; b < n; ++b) {
                const float v = sc[b] * pc[b] * dk[b];
                e[b] = v;
                lanes[b % 16] += v;
                k[b] = std::max(k[b], v * il);
            }
            double t = 0.0;
            for (int l = 0; l < 16; ++l) t += lanes[l];
            total[g][c] = t;
        }
    }
}

// Issue 25's per-channel step for a tile (bin_tree.h), before its kernel
// sum: which (bin, channel) pairs of the bins of varying colour are summed
// as that channel alone. A bin of varying colour can be off in channel c by
// at most its power P_c times the kernel's variation across it,
// dk = k(theta - beta) - k(theta + beta) at its distance theta from the
// nearest texel (inv_z k: the output's units), and by about min(1, s_c) of
// that (bin_tree.h's s_c: the first-order term k' n.d is dk/(2 beta) |d| at
// most, the second-order one likewise). Bins' errors of one sign add up (a
// sky's colour gradient puts every bin's blue above its red), so the
// budget is per tile: while the estimates of the channels taken whole add
// up to more than tol x the tile's least value in some channel (at least
// 0.05 x the channel's mean, the metric's floor), the (bin, channel) pair
// with the largest estimate against that bound is taken on its own
// instead: the bin's entry in acc loses that channel's power (a bin with
// every channel taken is dropped), and an entry of that channel alone, with
// its power and its own moments, is appended; the tile is then summed once.
// The tile's least value is that of its four corner texels' sums over the
// bins whole (the sum is smooth across a tile; summing every texel twice,
// once whole and once for the pairs, cost forest.exr a third more CPU than
// main, issue 25). The pairs are taken in buckets of the binary exponent of
// that ratio, largest first (within a factor 2 of the largest-first order,
// with no sort). tol 0: every channel of every bin of varying colour.
// Measured and refused: sub-tiles of 4 x 4 texels with their own budgets
// (fewer bins, more time), a cap on the pairs per tile, signs or quadrature
// for far or weak bins (issue 25: each left a source over 1 %, or saved
// under 7 %). count: the entries in acc, updated.
void chroma_pass(const BinTree& tree, const Tile& t, const std::vector<const BinNode*>& chromatic,
                 const std::vector<uint32_t>& chroma_at, const std::vector<float> (&tinted)[kernel::kTinted],
                 std::vector<float> (&acc)[kFields], size_t& count, const double* inv_zd, int K, const float* a2,
                 double tol, kernel::SumsFn sums) {
    double limit[kernel::kMaxLobes][3];
    float inv_limit[kernel::kMaxLobes][3];
    {
        float least[kernel::kMaxLobes][3];
        for (int g = 0; g < K; ++g) least[g][0] = least[g][1] = least[g][2] = INFINITY;
        const float* fields[kFields];
        for (int k = 0; k < kFields; ++k) fields[k] = acc[k].data();
        const size_t padded = acc[0].size();  // whole lanes (gather_bins)
        // The corners (each once), in one call where the lobes allow.
        const int ci[2] = {t.i0, t.i1 - 1}, cj[2] = {t.j0, t.j1 - 1};
        const int w = t.i1 - t.i0;
        float dirs[3 * 4];
        int corners = 0;
        for (int a = 0; a < 4; ++a) {
            if ((a & 1) && ci[1] == ci[0]) continue;
            if ((a & 2) && cj[1] == cj[0]) continue;
            const Vec3& d = t.dirs[size_t(cj[a >> 1] - t.j0) * w + size_t(ci[a & 1] - t.i0)];
            dirs[3 * corners] = d.x, dirs[3 * corners + 1] = d.y, dirs[3 * corners + 2] = d.z;
            ++corners;
        }
        double num[4][kernel::kMaxLobes][3];
        sums(fields, padded, K, a2, dirs, corners, num);
        for (int a = 0; a < corners; ++a)
            for (int g = 0; g < K; ++g)
                for (int c = 0; c < 3; ++c) least[g][c] = std::min(least[g][c], float(num[a][g][c] * inv_zd[g]));
        // Rounded down to an eighth of an octave: the limits, and so the
        // bins chosen, do not follow the sums' last bits (which differ
        // between the kernels of different instruction sets).
        for (int g = 0; g < K; ++g)
            for (int c = 0; c < 3; ++c) {
                int e = 0;
                const double m = std::frexp(std::max(0.05 * tree.channel_mean[c], double(least[g][c])), &e);
                limit[g][c] = tol * std::ldexp(std::floor(m * 16.0) / 16.0, e);
                inv_limit[g][c] = float(1.0 / limit[g][c]);
            }
    }
    // Each bin's estimates per lobe and channel (in lanes), their totals,
    // and the (bin, channel) pairs by their largest estimate against the
    // limits, in buckets of its binary exponent.
    const size_t n = chromatic.size();
    thread_local std::vector<float> est, key;
    thread_local std::vector<uint32_t> order;
    thread_local std::vector<uint8_t> bucket_of;
    est.resize(size_t(K) * 3 * n);
    key.resize(3 * n);
    const float* in[kernel::kTinted];  // the bins' rows, from gather_bins
    for (int r = 0; r < kernel::kTinted; ++r) in[r] = tinted[r].data();
    float inv_z[kernel::kMaxLobes];
    for (int g = 0; g < K; ++g) inv_z[g] = float(inv_zd[g]);
    double total[kernel::kMaxLobes][3] = {};
    chroma_estimates(in, n, t.c.x, t.c.y, t.c.z, std::cos(t.rho), std::sin(t.rho), K, a2, inv_z, inv_limit,
                     est.data(), key.data(), total);
    // How many of the (lobe, channel) totals are over their limits, kept up
    // to date below as the pairs' estimates come off: none, and the pass is done.
    int still_over = 0;
    for (int g = 0; g < K; ++g)
        for (int c = 0; c < 3; ++c) still_over += int(total[g][c] > limit[g][c]);
    if (still_over == 0) return;
    // The (bin, channel) pairs by bucket, largest first (in order of index within one).
    // (Four histograms in turn: one alone was a chain of stores and loads
    // of the same count, keys of one exponent being common.)
    // (Through local pointers: a byte's store may alias anything, and the
    // vectors' own pointers, thread-local, were loaded again after each.)
    uint32_t count_in[4][256] = {};
    bucket_of.resize(3 * n);
    {
        const float* kq = key.data();
        uint8_t* bq = bucket_of.data();
        // The exponents in lanes, then counted.
        for (size_t q = 0; q < 3 * n; ++q) {
            uint32_t bits;
            std::memcpy(&bits, &kq[q], sizeof(bits));
            bq[q] = uint8_t(kq[q] > 0.0f ? bits >> 23 : 0u);  // the exponent (keys are >= 0)
        }
        for (size_t q = 0; q < 3 * n; ++q) ++count_in[q & 3][bq[q]];
    }
    uint32_t start[256];
    uint32_t sum = 0;
    for (int k = 255; k >= 1; --k)
        start[k] = sum, sum += count_in[0][k] + count_in[1][k] + count_in[2][k] + count_in[3][k];
    start[0] = sum;  // keys of 0 after the rest, then cut off
    order.resize(3 * n);
    {
        const uint8_t* bq = bucket_of.data();
        uint32_t* oq = order.data();
        for (size_t q = 0; q < 3 * n; ++q) oq[start[bq[q]]++] = uint32_t(q);  // q = c n + b
    }
    order.resize(sum);
    thread_local std::vector<uint8_t> taken;  // per bin: its channels taken on their own (bits)
    thread_local std::vector<uint32_t> took;  // the bins taken, in the order first taken
    taken.assign(n, 0);
    took.resize(n);
    thread_local std::vector<const ChromaBin*> took_cb;  // their ChromaBins
    took_cb.resize(n);
    size_t nt = 0;
    {
        const float* eq = est.data();
        const BinNode* const* cq = chromatic.data();
        uint8_t* tq = taken.data();
        uint32_t* bq = took.data();
        const ChromaBin** cbq = took_cb.data();
        for (const uint32_t q : order) {
            if (still_over == 0) break;  // every total within its limit
            const int c = int(q >= n) + int(q >= 2 * n);  // q = c n + b
            const size_t b = q - size_t(c) * n;
            for (int g = 0; g < K; ++g) {
                const bool was = total[g][c] > limit[g][c];
                total[g][c] -= eq[(size_t(g) * 3 + c) * n + b];
                still_over += int(total[g][c] > limit[g][c]) - int(was);
            }
            if (!tq[b]) {
                const ChromaBin* cb = &tree.chroma_of(*cq[b]);
                __builtin_prefetch(cb);  // read below
                cbq[nt] = cb;
                bq[nt++] = uint32_t(b);
            }
            tq[b] |= uint8_t(1u << c);
        }
    }
    // The bins taken: their taken channels' power zeroed in place; the bins
    // with every channel taken dropped, each replaced by the last entry (in
    // decreasing order of place, so that the last is never one to drop).
    took.resize(nt);
    size_t extra = 0;
    bool any_drop = false;
    float* f[kFields];
    for (int k = 0; k < kFields; ++k) f[k] = acc[k].data();
    for (const uint32_t b : took) {
        const unsigned tk = taken[b];
        const uint32_t i = chroma_at[b];
        extra += size_t((tk & 1u) + (tk >> 1 & 1u) + (tk >> 2 & 1u));  // (no popcnt in the baseline x86-64)
        for (int c = 0; c < 3; ++c) {
            float& p = f[kernel::kP0 + c][i];
            p = tk >> c & 1u ? 0.0f : p;
        }
        any_drop |= tk == 7u;
    }
    size_t e = count;
    if (any_drop) {
        // The places to drop in decreasing order without a sort: chroma_at
        // grows with b, so b from the last down gives them in that order.
        thread_local std::vector<uint32_t> drop;
        drop.resize(n);
        const uint8_t* tq = taken.data();
        const uint32_t* at = chroma_at.data();
        size_t nd = 0;
        for (size_t b = n; b-- > 0;) {
            drop[nd] = at[b];
            nd += tq[b] == 7u;
        }
        for (size_t k = 0; k < nd; ++k) {
            const uint32_t i = drop[k];
            --e;
            for (int q = 0; q < kFields; ++q) f[q][i] = f[q][e];
        }
    }
    // Then each taken channel alone (its own moments), padded to whole
    // lanes with zeros.
    const size_t total_count = e + extra;
    const size_t padded = (total_count + kLanes - 1) / kLanes * kLanes;
    for (int k = 0; k < kFields; ++k) {
        acc[k].resize(std::max(padded, acc[k].size()));
        f[k] = acc[k].data();
    }
    for (size_t k0 = 0; k0 < nt; ++k0) {
        const uint32_t b = took[k0];
        const unsigned tk = taken[b];
        const BinNode* nd = chromatic[b];
        const ChromaBin& cb = *took_cb[k0];
        for (int c = 0; c < 3; ++c) {
            if (!(tk >> c & 1u)) continue;
            const ChromaChannel& ch = cb.channel[c];
            f[kernel::kPx][e] = ch.px, f[kernel::kPy][e] = ch.py, f[kernel::kPz][e] = ch.pz;
            f[kernel::kG][e] = ch.g;
            for (int cc = 0; cc < 3; ++cc) f[kernel::kP0 + cc][e] = cc == c ? nd->power[c] : 0.0f;
            for (int k = 0; k < 6; ++k) f[kernel::kCxx + k][e] = nd->cov[k] * ch.cov_scale;
            ++e;
        }
    }
    for (int k = 0; k < kFields; ++k) {
        acc[k].resize(padded);
        std::fill(acc[k].begin() + total_count, acc[k].end(), 0.0f);
    }
    count = total_count;
}

}  // namespace

double specular_hierarchical(Cubemap& dst, const BinTree& tree, double roughness, const HierarchicalQuality& q) {
    std::vector<SpecularGroupTarget> one{{&dst, roughness}};
    return specular_hierarchical_group(one, tree, q);
}

bool specular_group_safe(const std::vector<double>& roughness) {
    if (roughness.size() > size_t(kernel::kMaxLobes)) return false;
    for (double r : roughness)
        if (!(r > 0.0) || r > 1.0) return false;
    return true;
}

double specular_hierarchical_group(std::vector<SpecularGroupTarget>& targets, const BinTree& tree,
                                   const HierarchicalQuality& q) {
    if (targets.empty()) return 0.0;
    const int n = targets[0].dst->size;
    std::vector<double> rough;
    for (const SpecularGroupTarget& g : targets) {
        if (g.dst->size != n) throw std::invalid_argument("a specular group needs one face size");
        rough.push_back(g.roughness);
    }
    if (!specular_group_safe(rough))
        throw std::invalid_argument("a specular group takes 1 to 4 levels of roughness in (0, 1]");
    const int K = int(targets.size());
    // Per lobe: alpha^2 for the kernel, and the exact normaliser (the
    // integral of K over the sphere in closed form, in the units the kernel
    // uses, without the factor 4 a^2 / pi).
    float a2[kernel::kMaxLobes] = {0, 0, 0, 0};
    double inv_z[kernel::kMaxLobes] = {0, 0, 0, 0};
    const double eps_d = hierarchical_level_eps(q, n);
    // One traversal for all: the narrowest lobe's length scale and the
    // strictest horizon rule among them (bins at least as fine as each
    // lobe alone would use).
    double r_min = 1.0, horizon = kPi;
    for (int k = 0; k < K; ++k) {
        const double r = rough[k], alpha = r * r, a2d = alpha * alpha;
        const float af = float(alpha);
        a2[k] = af * af;
        inv_z[k] = 4.0 * a2d / (kPi * ggx::prefilter_normalizer(alpha));
        r_min = std::min(r_min, r);
        horizon = std::min(horizon, hierarchical_horizon_radius(r, n, q));
    }
    // The lobe's angular length scale in w: 2 alpha for narrow lobes, about
    // one radian (the cosine's) as alpha -> 1.
    const float alpha_min = float(r_min * r_min);
    const float scale = 2.0f * alpha_min / (1.0f + alpha_min);
    const float eps = float(eps_d);
    // K = D(h) max(0, n.w) has a kink at n's horizon with slope D(45 deg),
    // where no rule from a bin's moments is exact (a bin across it loses the
    // part of its radiance behind; by Jensen's inequality every such rule
    // comes out low). Relative to the kernel's integral Z that slope sets how
    // small bins that may straddle a horizon must be, in proportion to eps:
    // radius <= eps horizon / sqrt(D45 / Z) (hierarchical_horizon_radius).
    const float horizon_radius = float(horizon);
    const kernel::SumsFn sums = kernel_fn();
    // Tiles of at most a quarter of the face: a tile as wide as the face
    // would see every bin as near and take them all at the finest level.
    const int tile = q.tile > 0 ? q.tile : n >= 512 ? 16 : 8;
    const int T = std::max(1, std::min(tile, n / 4));
    const int tiles_per_row = (n + T - 1) / T, tiles = 6 * tiles_per_row * tiles_per_row;
    std::vector<double> used(tiles, 0.0);
    parallel_for(0, tiles, [&](int tile) {
        const Tile t = make_tile(tile, n, T);
        thread_local std::vector<float> acc[kFields];
        thread_local std::vector<const BinNode*> chromatic;
        thread_local std::vector<uint32_t> chroma_at;
        thread_local std::vector<float> tinted[kernel::kTinted];
        size_t count = gather_bins(tree, t, scale, eps, horizon_radius, acc, chromatic, chroma_at, tinted);
        if (!chromatic.empty() && q.chroma >= 0.0)
            chroma_pass(tree, t, chromatic, chroma_at, tinted, acc, count, inv_z, K, a2, q.chroma, sums);
        used[tile] = double(count);
        sum_tile(t, acc, K, a2, sums, [&](int i, int j, const double (*num)[3]) {
            for (int g = 0; g < K; ++g) {
                float* o = targets[g].dst->at(t.face, i, j);
                for (int ch = 0; ch < 3; ++ch) o[ch] = float(num[g][ch] * inv_z[g]);
            }
        });
    });
    double total = 0.0;
    for (double u : used) total += u;
    return total / tiles;
}

}  // namespace iblbake
