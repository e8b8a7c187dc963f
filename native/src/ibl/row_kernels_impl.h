// The SH9 projection's row sums, the bins' column sums, mip 0's lat-long coordinates and the
// irradiance's cosine sums (specular_kernel.h), included by one translation
// unit per instruction set (specular_kernel_*.cpp) with IBLBAKE_ISA_SUFFIX
// naming the functions it defines (sh9_row_<suffix>, ...); nothing else
// here has external linkage (math/fast_math.h's atan2_vec is static, so
// each unit has its own copy: no inline function built with these flags can
// be picked by the linker for another unit).
#include <cmath>
#include <cstddef>
#include <cstring>
#if defined(__AVX512F__)
#include <immintrin.h>  // row_pieces' conversions
#endif

#include "iblbake/math/fast_math.h"
#include "specular_kernel.h"

#define IBLBAKE_ROW_KERNEL_CAT(a, b) a##_##b
#define IBLBAKE_ROW_KERNEL_NAME(a, b) IBLBAKE_ROW_KERNEL_CAT(a, b)
#define IBLBAKE_ROW_KERNEL(name) IBLBAKE_ROW_KERNEL_NAME(name, IBLBAKE_ISA_SUFFIX)

namespace iblbake {
namespace kernel {

namespace {
typedef double Rgb8d __attribute__((vector_size(64)));
typedef float Rgb8f __attribute__((vector_size(32)));
typedef int Rgb8i __attribute__((vector_size(32)));

// Eight RGB pixels, the 24 floats from p, into one vector of doubles per
// channel (the SH9 row kernels').
inline void rgb8_to_doubles(const float* p, Rgb8d out[3]) {
    Rgb8f a, b, c3;
    std::memcpy(&a, p, sizeof(a));
    std::memcpy(&b, p + 8, sizeof(b));
    std::memcpy(&c3, p + 16, sizeof(c3));
    const Rgb8f r = __builtin_shuffle(__builtin_shuffle(a, b, Rgb8i{0, 3, 6, 9, 12, 15, 0, 0}), c3,
                                      Rgb8i{0, 1, 2, 3, 4, 5, 10, 13});
    const Rgb8f g = __builtin_shuffle(__builtin_shuffle(a, b, Rgb8i{1, 4, 7, 10, 13, 0, 0, 0}), c3,
                                      Rgb8i{0, 1, 2, 3, 4, 8, 11, 14});
    const Rgb8f bl = __builtin_shuffle(__builtin_shuffle(a, b, Rgb8i{2, 5, 8, 11, 14, 0, 0, 0}), c3,
                                       Rgb8i{0, 1, 2, 3, 4, 9, 12, 15});
    out[0] = __builtin_convertvector(r, Rgb8d);
    out[1] = __builtin_convertvector(g, Rgb8d);
    out[2] = __builtin_convertvector(bl, Rgb8d);
}
}  // namespace

// Lanes as GCC vectors of 8 doubles (zmm on AVX-512, whose 32 registers
// hold the 18 sums; plain arrays spilled them on every pixel), lane l the
// columns x0 + l as before, so every version adds the same products in the
// same order (only FMA rounding differs between instruction sets).
void IBLBAKE_ROW_KERNEL(sh9_row)(const float* row, int width, const double* const* wl, double (*t)[6]) {
    constexpr int kLanes8 = 8;  // independent partial sums, one vector of doubles on AVX-512
    typedef Rgb8d V8d;
    V8d acc[3][6];
    for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 6; ++k) acc[c][k] = V8d{};
    const int whole = width / kLanes8 * kLanes8;
    for (int x0 = 0; x0 < whole; x0 += kLanes8) {
        V8d v[3];
        rgb8_to_doubles(row + size_t(x0) * 3, v);
        for (int k = 0; k < 6; ++k) {
            V8d w;
            std::memcpy(&w, wl[k] + x0, sizeof(w));
            for (int c = 0; c < 3; ++c) acc[c][k] += v[c] * w;
        }
    }
    for (int x = whole; x < width; ++x)
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 6; ++k) acc[c][k][0] += double(row[3 * x + c]) * wl[k][x];
    for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 6; ++k) {
            double s = 0.0;
            for (int l = 0; l < kLanes8; ++l) s += acc[c][k][l];
            t[c][k] = s;
        }
}

// The same six sums from a quarter of the longitude tables: a row of width
// 4 n whose column x + j n lies a quarter turn j further on (phi - j pi / 2)
// has, at that column, cos and sin turned (cos phi -> sin, -cos, -sin) and
// cos 2 phi, sin 2 phi negated on odd quarters. So with L_j the radiance at
// x + j n, a = L0 - L2, b = L1 - L3 and g = (L0 + L2) - (L1 + L3):
//   sum L            over the whole row,
//   sum pc a + ps b  = the cos integral,   sum ps a - pc b = the sin integral,
//   sum d g          = the cos^2 integral less half the plain one (d = pcc - p0 / 2),
//   sum psc g        = the sin cos integral,
// where pc, ps, d, psc (q[0..3]) are column x's (x < n) and p0 every column's
// width in phi. Per pixel a quarter of the table reads and about half the
// arithmetic of sh9_row; the same sums, not the same rounding. No fused
// multiply-add (fp-contract off): with it, which product of pc a + ps b a
// compiler fuses is its own choice, and GCC 10 (the wheels) and 12 chose
// differently; without it every compiler and instruction set gives the
// same bits.
__attribute__((optimize("fp-contract=off"))) void IBLBAKE_ROW_KERNEL(sh9_row_quarter)(const float* row, int width,
                                                                                      const double* const* q,
                                                                                      double p0, double (*t)[6]) {
    constexpr int kLanes8 = 8;
    typedef Rgb8d V8d;
    const int n = width / 4;
    V8d acc[3][5];
    for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 5; ++k) acc[c][k] = V8d{};
    const int whole = n / kLanes8 * kLanes8;
    for (int x0 = 0; x0 < whole; x0 += kLanes8) {
        V8d L[4][3];
        for (int j = 0; j < 4; ++j) rgb8_to_doubles(row + size_t(x0 + j * n) * 3, L[j]);
        V8d pc, ps, d, psc;
        std::memcpy(&pc, q[0] + x0, sizeof(pc));
        std::memcpy(&ps, q[1] + x0, sizeof(ps));
        std::memcpy(&d, q[2] + x0, sizeof(d));
        std::memcpy(&psc, q[3] + x0, sizeof(psc));
        for (int c = 0; c < 3; ++c) {
            const V8d a = L[0][c] - L[2][c], b = L[1][c] - L[3][c];
            const V8d e = L[0][c] + L[2][c], f = L[1][c] + L[3][c], g = e - f;
            acc[c][0] += e + f;
            acc[c][1] += pc * a + ps * b;
            acc[c][2] += ps * a - pc * b;
            acc[c][3] += d * g;
            acc[c][4] += psc * g;
        }
    }
    for (int x = whole; x < n; ++x)
        for (int c = 0; c < 3; ++c) {
            const double l0 = row[3 * x + c], l1 = row[3 * (x + n) + c], l2 = row[3 * (x + 2 * n) + c],
                         l3 = row[3 * (x + 3 * n) + c];
            const double a = l0 - l2, b = l1 - l3, g = (l0 + l2) - (l1 + l3);
            acc[c][0][0] += (l0 + l2) + (l1 + l3);
            acc[c][1][0] += q[0][x] * a + q[1][x] * b;
            acc[c][2][0] += q[1][x] * a - q[0][x] * b;
            acc[c][3][0] += q[2][x] * g;
            acc[c][4][0] += q[3][x] * g;
        }
    for (int c = 0; c < 3; ++c) {
        double s[5];
        for (int k = 0; k < 5; ++k) {
            s[k] = 0.0;
            for (int l = 0; l < kLanes8; ++l) s[k] += acc[c][k][l];
        }
        t[c][0] = p0 * s[0];
        t[c][1] = s[1];
        t[c][2] = s[2];
        t[c][3] = 0.5 * p0 * s[0] + s[3];
        t[c][4] = 0.5 * p0 * s[0] - s[3];
        t[c][5] = s[4];
    }
}

// A bin row's five column sums (source.cpp's add_row_pieces), the whole
// blocks of kBlock columns: each block taken through every piece at once,
// its sums kept in registers (a 16K row's five sums, 2 MB of doubles, were
// read and written once per piece, about 64 times a bin row); returns the
// first column not summed. No fused multiply-add (fp-contract off) and each
// column's products added in the pieces' order, so every instruction set
// and block width gives the same bits: those of adding the pieces' products
// row by row. The block is as wide as the registers hold its 5 x kV sums
// (GCC's target_clones had given AVX2 twice as many as it has, spilled on
// every piece, and AVX-512 two half conversions and a shuffle for each
// vcvtps2pd).
__attribute__((optimize("fp-contract=off"))) size_t IBLBAKE_ROW_KERNEL(row_pieces)(const float* const* src,
                                                                                  const double* w, size_t pieces,
                                                                                  size_t n, double* const* out) {
#if defined(__AVX512F__)
    constexpr int kL = 8, kV = 2;  // 10 of 32 zmm (kV = 4 was 30 % slower)
#elif defined(__AVX2__)
    constexpr int kL = 4, kV = 2;  // 10 of 16 ymm
#else
    constexpr int kL = 2, kV = 2;  // 10 of 16 xmm
#endif
    constexpr size_t kBlock = size_t(kL) * kV;
    typedef double VD __attribute__((vector_size(8 * kL)));
    size_t i0 = 0;
    for (; i0 + kBlock <= n; i0 += kBlock) {
        VD acc[5][kV], v[kV];
        auto load = [&](size_t p) {
            for (int q = 0; q < kV; ++q) {
#if defined(__AVX512F__)
                v[q] = VD(_mm512_maskz_cvtps_pd(__mmask8(0xff), _mm256_loadu_ps(src[p] + i0 + kL * q)));
#else
                typedef float VF __attribute__((vector_size(4 * kL)));
                VF f;
                std::memcpy(&f, src[p] + i0 + kL * q, sizeof(f));
                v[q] = __builtin_convertvector(f, VD);
#endif
            }
        };
        load(0);
        for (int k = 0; k < 5; ++k)
            for (int q = 0; q < kV; ++q) acc[k][q] = v[q] * w[k];
        for (size_t p = 1; p < pieces; ++p) {
            load(p);
            for (int k = 0; k < 5; ++k) {
                const double wk = w[5 * p + k];
                for (int q = 0; q < kV; ++q) acc[k][q] += v[q] * wk;
            }
        }
        for (int k = 0; k < 5; ++k) std::memcpy(out[k] + i0, acc[k], sizeof(acc[k]));
    }
    return i0;
}

// A bin row's band-2 SH9 sums from its column sums (source.cpp's
// BinReduction::row): per channel c, over the values i = 3 x + c,
// t[c] = {sum cs2, sum q, sum q h2, sum q h3, sum cc1 h0, sum cc1 h1}, q =
// cs0 - cs2, h[0..3] column x's full-hat longitude integrals (sh9_hat_tables).
// Value i goes to lane i mod 24 (three vectors of 8 doubles per sum, each
// lane one channel's), the lanes added in order at the end; no fused
// multiply-add: every instruction set gives the same bits.
__attribute__((optimize("fp-contract=off"))) void IBLBAKE_ROW_KERNEL(sh9_band2)(const double* cs0, const double* cs2,
                                                                                const double* cc1,
                                                                                const double* const* h, size_t width,
                                                                                double (*t)[6]) {
    typedef Rgb8d V8d;
    typedef long long V8l __attribute__((vector_size(64)));
    V8d acc[6][3];
    for (auto& a : acc)
        for (V8d& v : a) v = V8d{};
    auto add = [&](int b, const V8d* e, size_t i) {
        V8d a0, a2, c1;
        std::memcpy(&a0, cs0 + i, sizeof(a0));
        std::memcpy(&a2, cs2 + i, sizeof(a2));
        std::memcpy(&c1, cc1 + i, sizeof(c1));
        const V8d q = a0 - a2;
        acc[0][b] += a2;
        acc[1][b] += q;
        acc[2][b] += q * e[2];
        acc[3][b] += q * e[3];
        acc[4][b] += c1 * e[0];
        acc[5][b] += c1 * e[1];
    };
    const size_t whole = width / 8 * 8;
    for (size_t x0 = 0; x0 < whole; x0 += 8) {
        V8d hv[4], e[4];
        for (int k = 0; k < 4; ++k) std::memcpy(&hv[k], h[k] + x0, sizeof(hv[k]));
        // Each column's table values beside its three channels' values.
        for (int k = 0; k < 4; ++k) e[k] = __builtin_shuffle(hv[k], V8l{0, 0, 0, 1, 1, 1, 2, 2});
        add(0, e, 3 * x0);
        for (int k = 0; k < 4; ++k) e[k] = __builtin_shuffle(hv[k], V8l{2, 3, 3, 3, 4, 4, 4, 5});
        add(1, e, 3 * x0 + 8);
        for (int k = 0; k < 4; ++k) e[k] = __builtin_shuffle(hv[k], V8l{5, 5, 6, 6, 6, 7, 7, 7});
        add(2, e, 3 * x0 + 16);
    }
    for (size_t i = 3 * whole; i < 3 * width; ++i) {
        const size_t lane = i % 24, b = lane / 8, l = lane % 8, x = i / 3;
        const double q = cs0[i] - cs2[i];
        acc[0][b][l] += cs2[i];
        acc[1][b][l] += q;
        acc[2][b][l] += q * h[2][x];
        acc[3][b][l] += q * h[3][x];
        acc[4][b][l] += cc1[i] * h[0][x];
        acc[5][b][l] += cc1[i] * h[1][x];
    }
    for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 6; ++k) {
            double s = 0.0;
            for (int lane = c; lane < 24; lane += 3) s += acc[k][lane / 8][lane % 8];
            t[c][k] = s;
        }
}

void IBLBAKE_ROW_KERNEL(mirror_row)(const double* frame, double b, int n, int w, int h, double* fx, double* fy) {
    constexpr double kPiD = 3.14159265358979323846;
    for (int i = 0; i < n; ++i) {
        const double a = 2.0 * (i + 0.5) / n - 1.0;
        const double ex = frame[0] + frame[3] * a + frame[6] * b, ey = frame[1] + frame[4] * a + frame[7] * b,
                     ez = frame[2] + frame[5] * a + frame[8] * b;
        // Blender (x, y, z) = (ex, -ez, ey); the length cancels in both angles.
        const double bx = ex, by = -ez, bz = ey;
        const double u = 0.5 - atan2_vec(by, bx) * (0.5 / kPiD);
        const double v = 0.5 + atan2_vec(bz, std::sqrt(bx * bx + by * by)) * (1.0 / kPiD);
        fx[i] = (u - std::floor(u)) * w - 0.5;
        fy[i] = (1.0 - v) * h - 0.5;
    }
}

void IBLBAKE_ROW_KERNEL(irr_horizon)(const float* cx, const float* cy, const float* cz, const float* sin_radius,
                                     size_t count, float nx, float ny, float nz, float* whole) {
    for (size_t p = 0; p < count; ++p) {
        const float d = nx * cx[p] + ny * cy[p] + nz * cz[p];
        whole[p] = (d < 0.0f ? -d : d) > sin_radius[p] ? 1.0f : 0.0f;
    }
}

double IBLBAKE_ROW_KERNEL(irr_sum)(const float* x, const float* y, const float* z, const float* whole, size_t count,
                                   float nx, float ny, float nz) {
    constexpr size_t kLanes16 = 16, kBlock256 = 256;
    double total = 0.0;
    for (size_t b = 0; b < count; b += kBlock256) {
        const size_t e = count < b + kBlock256 ? count : b + kBlock256;
        float s[kLanes16] = {};
        for (size_t p = b; p < e; p += kLanes16)
            for (size_t l = 0; l < kLanes16; ++l) {
                const float v = nx * x[p + l] + ny * y[p + l] + nz * z[p + l];
                s[l] += whole[p + l] * (v > 0.0f ? v : 0.0f);
            }
        float t = 0.0f;
        for (size_t l = 0; l < kLanes16; ++l) t += s[l];
        total += t;
    }
    return total;
}

#undef IBLBAKE_ROW_KERNEL
#undef IBLBAKE_ROW_KERNEL_NAME
#undef IBLBAKE_ROW_KERNEL_CAT

}  // namespace kernel
}  // namespace iblbake
