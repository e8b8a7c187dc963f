#include "iblbake/ibl/irradiance.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "iblbake/ibl/cube_sampling.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/latlong.h"
#include "iblbake/util/parallel.h"
#include "specular_kernel.h"

namespace iblbake {

namespace {

// Whether the 16 flags at f (each exactly 0.0f or 1.0f) are all `value`
// (1.0f or 0.0f), from their bits: their AND is 1.0f's only when all are
// 1.0f, their OR 0 only when all are 0.0f (a float sum was a chain of 16
// dependent adds).
inline bool all_flags(const float* f, float value) {
    uint32_t want;
    std::memcpy(&want, &value, sizeof want);
#ifdef __SSE2__
    const __m128i* v = reinterpret_cast<const __m128i*>(f);
    const __m128i a = _mm_loadu_si128(v), b = _mm_loadu_si128(v + 1), c = _mm_loadu_si128(v + 2),
                  d = _mm_loadu_si128(v + 3);
    const __m128i all = want ? _mm_and_si128(_mm_and_si128(a, b), _mm_and_si128(c, d))
                             : _mm_or_si128(_mm_or_si128(a, b), _mm_or_si128(c, d));
    return _mm_movemask_epi8(_mm_cmpeq_epi32(all, _mm_set1_epi32(int(want)))) == 0xffff;
#else
    uint32_t all = want ? ~0u : 0u;
    for (int l = 0; l < 16; ++l) {
        uint32_t b;
        std::memcpy(&b, f + l, sizeof b);
        all = want ? all & b : all | b;
    }
    return all == want;
#endif
}

// One output direction against the bin groups: the groups in kLanes
// independent float partials (kernel::irr_sum_fn, built for the CPU's
// vectors; the order is fixed),
// those across n's horizon then bin by bin, float within blocks, double
// across them.
void convolve_direction(const BinGroups& g, const Vec3d& n, float out[3]) {
    constexpr size_t kLanes = 16;  // kernel::irr_sum_fn's
    const float nx = float(n.x), ny = float(n.y), nz = float(n.z);
    const size_t count = size_t(g.count), whole = count / kLanes * kLanes;
    const kernel::IrrSumFn sum = kernel::irr_sum_fn();
    // whole[p]: 1 for a group wholly on one side of n's horizon (then
    // max(0, n.V) of its sum is exact: all of it, or none), else 0.
    thread_local std::vector<float> whole_group;
    thread_local std::vector<uint32_t> across;  // the other groups, by index (a branch-free compaction)
    whole_group.resize(count);
    across.resize(count + 1);
    float* wg = whole_group.data();
    uint32_t* ac = across.data();
    const float *cx = g.cx.data(), *cy = g.cy.data(), *cz = g.cz.data(), *sr = g.sin_radius.data();
    kernel::irr_horizon_fn()(cx, cy, cz, sr, count, nx, ny, nz, wg);  // vectorised for the CPU
    // Branch-free compaction, 16 groups at a time; most runs lie wholly on
    // one side (only a band about the horizon's great circle is across), and
    // a run whose flags are all 1 is skipped after one vectorised test.
    size_t n_across = 0;
    for (size_t p0 = 0; p0 < count; p0 += kLanes) {
        const size_t e = std::min(count, p0 + kLanes);
        if (e - p0 == kLanes && all_flags(wg + p0, 1.0f)) continue;
        for (size_t p = p0; p < e; ++p) {
            uint32_t bits;  // the flag's bits: 0.0f is 0 (a float compare costs a parity test too)
            std::memcpy(&bits, wg + p, sizeof bits);
            ac[n_across] = uint32_t(p);
            n_across += bits == 0u;
        }
    }
    double total[3];
    for (int c = 0; c < 3; ++c) {
        const float* x = g.vx[c].data();
        const float* y = g.vy[c].data();
        const float* z = g.vz[c].data();
        total[c] = sum(x, y, z, wg, whole, nx, ny, nz);
        for (size_t p = whole; p < count; ++p) total[c] += wg[p] * std::max(0.0f, nx * x[p] + ny * y[p] + nz * z[p]);
    }
    // Groups across the horizon, bin by bin. The four bins' cosines side by
    // side (each evaluated as before), added in their order: the same sum to
    // the bit, a quarter of the arithmetic instructions; the three channels'
    // sums in one loop (three chains of adds side by side, each in its order).
    float t[3] = {0.0f, 0.0f, 0.0f};
    for (size_t q = 0; q < n_across; ++q) {
        const size_t k = 4 * size_t(ac[q]);
        for (int c = 0; c < 3; ++c) {
            const float *bx = g.bx[c].data(), *by = g.by[c].data(), *bz = g.bz[c].data();
            float d[4];
#ifdef __SSE2__
            // max(v, 0) as maxps takes it: 0 for NaN and -0, as std::max(0, v).
            const __m128 v = _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_set1_ps(nx), _mm_loadu_ps(bx + k)),
                                                   _mm_mul_ps(_mm_set1_ps(ny), _mm_loadu_ps(by + k))),
                                        _mm_mul_ps(_mm_set1_ps(nz), _mm_loadu_ps(bz + k)));
            _mm_storeu_ps(d, _mm_max_ps(v, _mm_setzero_ps()));
#else
            for (int l = 0; l < 4; ++l) d[l] = std::max(0.0f, nx * bx[k + l] + ny * by[k + l] + nz * bz[k + l]);
#endif
            t[c] += d[0];
            t[c] += d[1];
            t[c] += d[2];
            t[c] += d[3];
        }
    }
    for (int c = 0; c < 3; ++c) out[c] = float((total[c] + t[c]) / kPi);
}

// H(x) = phi(x) - x Phi(-x) on [0, 5] (bench/fit_horizon_excess.py prints
// the table: eight intervals of width 0.625, each a polynomial of degree 12
// in t = (x - centre) / 0.3125, within 3e-17 of H).
constexpr int kExcessIntervals = 8, kExcessCoeffs = 13;
constexpr double kExcess[kExcessIntervals][kExcessCoeffs] = {
    {2.6201489322055185e-1, -1.1791571297807605e-1, 1.8551299130792365e-2, -6.0388343524319525e-4, -1.3622761088079346e-4, 8.5579946657195156e-6, 1.1910574829927565e-6, -9.6210651512455756e-8, -9.210745086396454e-9, 8.8272692584449757e-10, 6.1330872074396384e-11, -6.6696352472514912e-12, -3.4725609121925561e-13},
    {9.3713864958726239e-2, -5.4453347462669488e-2, 1.2552436882164791e-2, -1.2258239142739955e-3, -1.2369967885205833e-5, 1.2695739469321451e-5, -4.9910868386954e-7, -9.7188901174176618e-8, 7.9110384461632641e-9, 5.3340856781053716e-10, -7.5702466505298193e-11, -1.7754161077249657e-12, 5.370840919915753e-13},
    {2.5376506642027001e-2, -1.8464100916458529e-2, 5.7469243761874971e-3, -9.3537180602230611e-4, 6.7412538363691935e-5, 2.5512346112436772e-6, -8.6594557376245589e-7, 3.6675508678192671e-8, 5.3119507713514021e-9, -5.8655711999389663e-10, -1.1707548214449289e-11, 4.6050324775472617e-12, -1.0782447723131477e-13},
    {5.0635984069385178e-3, -4.4853192527505606e-3, 1.7803141199312557e-3, -4.0567053513936914e-4, 5.4840227197464114e-5, -3.5360610021566043e-6, -1.3267756160335365e-7, 4.5844298560477075e-8, -2.7604993674098481e-9, -1.6346401012686747e-10, 3.2136582436015684e-11, -7.9177756031154395e-13, -1.6533974832616285e-13},
    {7.2975876350571793e-4, -7.680941172489691e-4, 3.7317411224347842e-4, -1.0932835319621295e-4, 2.0985444531668013e-5, -2.6211879733512892e-6, 1.7902710053765085e-7, 1.9003205646239763e-9, -1.7697688931208542e-9, 1.5735869763475643e-10, -3.8630744727614076e-13, -1.0823760225613374e-12, 8.0351362441504317e-14},
    {7.4855449967251348e-5, -9.1736049922481656e-5, 5.2927343706769682e-5, -1.8951848332762783e-5, 4.6588838807558879e-6, -8.1585543779733093e-7, 1.0057095547423382e-7, -7.8456668119359687e-9, 1.7658552896723866e-10, 4.2783271618982886e-11, -5.9363811607363531e-12, 2.663452880547783e-13, 1.5269407702063841e-14},
    {5.4066334748854532e-6, -7.5859293302162458e-6, 5.0792829476406847e-6, -2.1494361431798965e-6, 6.4085877797767216e-7, -1.41727461979124e-7, 2.372952041479155e-8, -2.9854734515348654e-9, 2.6686420239248772e-10, -1.3349007670234139e-11, -3.3259211226460805e-13, 1.3419070794897267e-13, -1.1741695261935795e-14},
    {2.7279776484565009e-7, -4.3212922075390854e-7, 3.2982109746797234e-7, -1.6104545772687281e-7, 5.6292517098019244e-8, -1.4919238989736438e-8, 3.0926606901356425e-9, -5.084222854317316e-10, 6.612910394543931e-11, -6.6266167772525421e-12, 4.6834139804451371e-13, -1.4529920982206269e-14, -1.3061988570065044e-15},
};

}  // namespace

double horizon_excess(double x) {
    const int i = std::min(kExcessIntervals - 1, int(x * 1.6));
    const double t = (x - (0.3125 + 0.625 * i)) * 3.2;
    double p = kExcess[i][kExcessCoeffs - 1];
    for (int c = kExcessCoeffs - 2; c >= 0; --c) p = p * t + kExcess[i][c];
    return p;
}

namespace {

// The hot points as structure-of-arrays: mean direction m, covariance,
// power, and 5 sqrt(trace C), beyond which |n.m| is surely 5 sigma from n's
// horizon.
struct HotPoints {
    size_t count = 0;
    std::vector<float> mx, my, mz, c[6], p[3], reach;
    explicit HotPoints(const std::vector<RadiancePoint>& hot) : count(hot.size()) {
        for (auto* v : {&mx, &my, &mz, &reach}) v->resize(count);
        for (auto& v : c) v.resize(count);
        for (auto& v : p) v.resize(count);
        for (size_t k = 0; k < count; ++k) {
            mx[k] = hot[k].mean_dir[0], my[k] = hot[k].mean_dir[1], mz[k] = hot[k].mean_dir[2];
            for (int i = 0; i < 6; ++i) c[i][k] = hot[k].cov[i];
            for (int i = 0; i < 3; ++i) p[i][k] = hot[k].power[i];
            reach[k] = 5.0f * std::sqrt(std::max(0.0f, c[0][k] + c[1][k] + c[2][k]));
        }
    }
};

// The hot points' share, (1/pi) sum P_c E[max(0, n.w)] over each point's hat:
// P max(0, mu) in one vectorised pass (fixed lanes), which also marks the
// points within 5 sigma of n's horizon; runs of 16 with none marked are
// skipped, and the few marked are corrected to the Gaussian model's value.
// Built per instruction set without fused multiply-add (the lanes fixed):
// the same bits on every CPU, 16 points an instruction with AVX-512.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default"), optimize("fp-contract=off")))
#endif
void hot_direction(const HotPoints& h, const Vec3d& n, float out[3]) {
    if (h.count == 0) return;
    constexpr size_t kLanes = 16;
    const float nx = float(n.x), ny = float(n.y), nz = float(n.z);
    thread_local std::vector<uint32_t> near;
    thread_local std::vector<float> marked;  // 1 for a point within reach of n's horizon, else 0
    near.resize(h.count + 1);
    marked.resize(h.count);
    size_t n_near = 0;
    float s0[kLanes], s1[kLanes], s2[kLanes];
    const size_t whole = h.count / kLanes * kLanes;
    const float *mx = h.mx.data(), *my = h.my.data(), *mz = h.mz.data(), *reach = h.reach.data();
    float* mk = marked.data();
    const float *p0 = h.p[0].data(), *p1 = h.p[1].data(), *p2 = h.p[2].data();
    // Point k's term into lane k % 16, 16 points at a time as one vector
    // (GCC's vector extension: one AVX-512 register, two AVX2 or four SSE
    // ones, the same operations lane by lane), then the last points into
    // lane 0 one by one.
    {
        typedef float V16 __attribute__((vector_size(64)));
        typedef int32_t I16 __attribute__((vector_size(64)));
        const V16 zero = V16{} + 0.0f, one = zero + 1.0f;
        V16 a0 = zero, a1 = zero, a2 = zero;
        for (size_t k0 = 0; k0 < whole; k0 += kLanes) {
            V16 x, y, z, q0, q1, q2, r;
            std::memcpy(&x, mx + k0, sizeof x), std::memcpy(&y, my + k0, sizeof y), std::memcpy(&z, mz + k0, sizeof z);
            std::memcpy(&q0, p0 + k0, sizeof q0), std::memcpy(&q1, p1 + k0, sizeof q1);
            std::memcpy(&q2, p2 + k0, sizeof q2), std::memcpy(&r, reach + k0, sizeof r);
            const V16 mu = nx * x + ny * y + nz * z;
            const V16 e = zero < mu ? mu : zero;  // std::max(0.0f, mu)
            a0 += q0 * e;
            a1 += q1 * e;
            a2 += q2 * e;
            const V16 amu = (V16)((I16)mu & (I16{} + 0x7fffffff));  // std::fabs
            const V16 mark = amu < r ? one : zero;
            std::memcpy(mk + k0, &mark, sizeof mark);
        }
        std::memcpy(s0, &a0, sizeof s0), std::memcpy(s1, &a1, sizeof s1), std::memcpy(s2, &a2, sizeof s2);
    }
    for (size_t k = whole; k < h.count; ++k) {
        const float mu = nx * mx[k] + ny * my[k] + nz * mz[k];
        const float e = std::max(0.0f, mu);
        s0[0] += p0[k] * e;
        s1[0] += p1[k] * e;
        s2[0] += p2[k] * e;
        mk[k] = std::fabs(mu) < reach[k] ? 1.0f : 0.0f;
    }
    for (size_t k0 = 0; k0 < h.count; k0 += kLanes) {  // branch-free compaction of the runs with any marked
        const size_t e = std::min(h.count, k0 + kLanes);
        if (e - k0 == kLanes && all_flags(mk + k0, 0.0f)) continue;
        for (size_t k = k0; k < e; ++k) {
            near[n_near] = uint32_t(k);
            n_near += mk[k] != 0.0f;
        }
    }
    double acc[3] = {0, 0, 0};
    for (size_t l = 0; l < kLanes; ++l) acc[0] += s0[l], acc[1] += s1[l], acc[2] += s2[l];
    // The marked points within 5 sigma of the horizon: P (E[max(0, X)] -
    // max(0, mu)) = P sigma H(|mu| / sigma) (horizon_excess: a polynomial,
    // where erfc and exp were half of this function's time), mu the float
    // cosine the pass above took.
    for (size_t q = 0; q < n_near; ++q) {
        const size_t k = near[q];
        const float mu = nx * mx[k] + ny * my[k] + nz * mz[k];
        const double var = h.c[0][k] * nx * nx + h.c[1][k] * ny * ny + h.c[2][k] * nz * nz +
                           2.0 * (h.c[3][k] * nx * ny + h.c[4][k] * nx * nz + h.c[5][k] * ny * nz);
        if (!(var > 0.0) || !(double(mu) * double(mu) < 25.0 * var)) continue;
        const double sigma = std::sqrt(var), d = sigma * horizon_excess(std::fabs(double(mu)) / sigma);
        for (int ch = 0; ch < 3; ++ch) acc[ch] += h.p[ch][k] * d;
    }
    for (int ch = 0; ch < 3; ++ch) out[ch] += float(acc[ch] / kPi);
}

void convolve_cube(Cubemap& dst, const BinGroups& cloud, const HotPoints& hot) {
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) {
            const Vec3d d = texel_direction(f, i, j, n);
            convolve_direction(cloud, d, dst.at(f, i, j));
            hot_direction(hot, d, dst.at(f, i, j));
        }
    });
}

}  // namespace

BinGroups group_bins(const std::vector<Bin>& bins, int bw, int bh, double bright) {
    BinGroups g;
    // The bright bins (BinGroups::points): above `bright` x the mean power.
    double total = 0.0;
    for (const Bin& b : bins) total += b.power[0] + b.power[1] + b.power[2];
    const double limit = bright * total / std::max<size_t>(1, bins.size());
    std::vector<char> is_point(bins.size(), 0);
    for (size_t k = 0; k < bins.size(); ++k) {
        const Bin& b = bins[k];
        const double p = b.power[0] + b.power[1] + b.power[2];
        if (!(p > limit)) continue;
        is_point[k] = 1;
        for (int ch = 0; ch < 3; ++ch) {
            const double pc = b.power[ch];
            const Vec3d v{b.vector[ch][0], b.vector[ch][1], b.vector[ch][2]};
            if (!(pc > 0.0) || !(length(v) > 0.0)) continue;
            const Vec3d m = v / pc, d = normalize(v);
            const double* s2 = b.second;  // the channels' sum: its spread about this channel's mean
            const double cov[6] = {s2[0] / p - m.x * m.x, s2[1] / p - m.y * m.y, s2[2] / p - m.z * m.z,
                                   s2[3] / p - m.x * m.y, s2[4] / p - m.x * m.z, s2[5] / p - m.y * m.z};
            RadiancePoint q{};
            q.dir[0] = float(d.x), q.dir[1] = float(d.y), q.dir[2] = float(d.z);
            q.mean_dir[0] = float(m.x), q.mean_dir[1] = float(m.y), q.mean_dir[2] = float(m.z);
            q.power[ch] = float(pc);
            for (int i = 0; i < 6; ++i) q.cov[i] = float(cov[i]);
            g.points.push_back(q);
        }
    }
    const int gw = (bw + 1) / 2, gh = (bh + 1) / 2;
    g.count = gw * gh;
    for (auto* v : {&g.cx, &g.cy, &g.cz, &g.sin_radius}) v->resize(g.count);
    for (int c = 0; c < 3; ++c) {
        for (auto* v : {&g.vx[c], &g.vy[c], &g.vz[c]}) v->assign(g.count, 0.0f);
        for (auto* v : {&g.bx[c], &g.by[c], &g.bz[c]}) v->assign(size_t(4) * g.count, 0.0f);
    }
    for (int gy = 0; gy < gh; ++gy)
        for (int gx = 0; gx < gw; ++gx) {
            const int k = gy * gw + gx;
            // The group's rectangle: bins 2gx .. 2gx+1 (clipped), rows likewise.
            const int x1 = std::min(bw, 2 * gx + 2), y1 = std::min(bh, 2 * gy + 2);
            const double u0 = double(2 * gx) / bw, u1 = double(x1) / bw;
            const double v0 = 1.0 - double(y1) / bh, v1 = 1.0 - double(2 * gy) / bh;
            Vec3d c = rect_moment(lon_integrals(u0, u1), lat_integrals(v0, v1));
            c = length(c) > 0.0 ? normalize(c) : blender_to_engine(latlong_to_direction(0.5 * (u0 + u1), 0.5 * (v0 + v1)));
            double min_cos = 1.0;
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) {
                    const Vec3d p = blender_to_engine(latlong_to_direction(u0 + 0.5 * i * (u1 - u0), v0 + 0.5 * j * (v1 - v0)));
                    min_cos = std::min(min_cos, dot(c, p));
                }
            const double radius = std::acos(std::clamp(min_cos, -1.0, 1.0)) * (1.0 + 1e-6) + 1e-6;
            g.cx[k] = float(c.x), g.cy[k] = float(c.y), g.cz[k] = float(c.z);
            g.sin_radius[k] = radius < 0.5 * kPi ? float(std::sin(radius)) : 2.0f;
            int m = 4 * k;
            for (int y = 2 * gy; y < y1; ++y)
                for (int x = 2 * gx; x < x1; ++x, ++m) {
                    if (is_point[size_t(y) * bw + x]) continue;
                    const Bin& b = bins[size_t(y) * bw + x];
                    for (int ch = 0; ch < 3; ++ch) {
                        g.bx[ch][m] = float(b.vector[ch][0]), g.by[ch][m] = float(b.vector[ch][1]);
                        g.bz[ch][m] = float(b.vector[ch][2]);
                        g.vx[ch][k] += float(b.vector[ch][0]), g.vy[ch][k] += float(b.vector[ch][1]);
                        g.vz[ch][k] += float(b.vector[ch][2]);
                    }
                }
        }
    return g;
}

void irradiance_convolve(Cubemap& dst, const BinGroups& cloud, const std::vector<RadiancePoint>& hot,
                         int exact_face_limit) {
    std::vector<RadiancePoint> all(hot);
    all.insert(all.end(), cloud.points.begin(), cloud.points.end());
    const HotPoints points(all);
    if (dst.size <= exact_face_limit) {
        convolve_cube(dst, cloud, points);
        return;
    }
    Cubemap coarse(exact_face_limit);
    convolve_cube(coarse, cloud, points);
    const BorderedCube src = BorderedCube::from_cube(coarse);
    const int n = dst.size;
    parallel_for(0, 6 * n, [&](int row) {
        const int f = row / n, j = row % n;
        for (int i = 0; i < n; ++i) src.bilinear(Vec3(texel_direction(f, i, j, n)), dst.at(f, i, j));
    });
}

}  // namespace iblbake
