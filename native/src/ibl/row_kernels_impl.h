// The bins' column sums and their SH9 band-2 sums, mip 0's lat-long
// coordinates and the irradiance's cosine sums (specular_kernel.h), included
// by one translation unit per instruction set (specular_kernel_*.cpp) with
// IBLBAKE_ISA_SUFFIX naming the functions it defines (row_pieces_<suffix>,
// ...); nothing else here has external linkage (math/fast_math.h's atan2_vec
// is static, so each unit has its own copy: no inline function built with
// these flags can be picked by the linker for another unit).
#include <cmath>
#include <cstddef>
#include <cstring>

#include "iblbake/math/fast_math.h"
#include "specular_kernel.h"

#define IBLBAKE_ROW_KERNEL_CAT(a, b) a##_##b
#define IBLBAKE_ROW_KERNEL_NAME(a, b) IBLBAKE_ROW_KERNEL_CAT(a, b)
#define IBLBAKE_ROW_KERNEL(name) IBLBAKE_ROW_KERNEL_NAME(name, IBLBAKE_ISA_SUFFIX)

namespace iblbake {
namespace kernel {

namespace {
typedef double V8d __attribute__((vector_size(64)));  // eight doubles: one zmm on AVX-512
}  // namespace

// A bin row's five column sums (source.cpp's add_row_pieces), the whole
// blocks of kBlock values: each block taken through every piece at once,
// its sums kept in registers (a 16K row's five sums were read and written
// once per piece, about 64 times a bin row), then rebuilt in double
// (rebuild_sums) and stored; returns the first value not summed. The sums
// are in float: they run over one bin row's pieces (a few dozen source
// rows) on centred weights, and float vectors hold twice as many values
// with no conversion per piece (in double, with a vcvtps2pd per vector and
// piece, this was 7.6 % of a 16K bake's CPU). No fused multiply-add
// (fp-contract off) and each value's products added in the pieces' order,
// so every instruction set and block width gives the same bits: those of
// adding the pieces' products row by row. The block is as wide as the
// registers hold its 5 x kV sums.
__attribute__((optimize("fp-contract=off"))) size_t IBLBAKE_ROW_KERNEL(row_pieces)(const float* const* src,
                                                                                  const float* w, size_t pieces,
                                                                                  size_t n, const double* centre,
                                                                                  double* const* out) {
#if defined(__AVX512F__)
    constexpr int kL = 16, kV = 2;  // 10 of 32 zmm
#elif defined(__AVX2__)
    constexpr int kL = 8, kV = 2;  // 10 of 16 ymm
#else
    constexpr int kL = 4, kV = 2;  // 10 of 16 xmm
#endif
    constexpr size_t kBlock = size_t(kL) * kV;
    typedef float VF __attribute__((vector_size(4 * kL)));
    typedef double VD __attribute__((vector_size(8 * kL)));
    size_t i0 = 0;
    for (; i0 + kBlock <= n; i0 += kBlock) {
        VF acc[5][kV], v[kV];
        auto load = [&](size_t p) {
            for (int q = 0; q < kV; ++q) std::memcpy(&v[q], src[p] + i0 + kL * q, sizeof(v[q]));
        };
        load(0);
        for (int k = 0; k < 5; ++k)
            for (int q = 0; q < kV; ++q) acc[k][q] = v[q] * w[k];
        for (size_t p = 1; p < pieces; ++p) {
            load(p);
            for (int k = 0; k < 5; ++k) {
                const float wk = w[5 * p + k];
                for (int q = 0; q < kV; ++q) acc[k][q] += v[q] * wk;
            }
        }
        for (int q = 0; q < kV; ++q) {
            VD S[5], raw[5];
            for (int k = 0; k < 5; ++k) S[k] = __builtin_convertvector(acc[k][q], VD);
            rebuild_sums(S, centre, raw);
            for (int k = 0; k < 5; ++k) std::memcpy(out[k] + i0 + kL * q, &raw[k], sizeof(raw[k]));
        }
    }
    return i0;
}

// A bin row's band-2 SH9 sums from its column sums (source.cpp's
// BinReduction::row), added into acc (specular_kernel.h): per channel c,
// over the values i = 3 x + c, {sum cs2, sum q, sum q h2, sum q h3,
// sum cc1 h0, sum cc1 h1}, q = cs0 - cs2, h[0..3] column x's full-hat
// longitude integrals (sh9_hat_tables). Value i goes to lane i mod 24 (three
// vectors of 8 doubles per sum, each lane one channel's); the caller adds
// the lanes in order. No fused multiply-add: every instruction set gives
// the same bits.
__attribute__((optimize("fp-contract=off"))) void IBLBAKE_ROW_KERNEL(sh9_band2)(const double* cs0, const double* cs2,
                                                                                const double* cc1,
                                                                                const double* const* h, size_t width,
                                                                                double (*lanes)[24]) {
    typedef long long V8l __attribute__((vector_size(64)));
    V8d acc[6][3];
    std::memcpy(acc, lanes, sizeof(acc));
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
    std::memcpy(lanes, acc, sizeof(acc));
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
