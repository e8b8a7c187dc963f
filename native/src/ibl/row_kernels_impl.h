// The SH9 projection's row sums, mip 0's lat-long coordinates and the
// irradiance's cosine sums (specular_kernel.h), included by one translation
// unit per instruction set (specular_kernel_*.cpp) with IBLBAKE_ISA_SUFFIX
// naming the functions it defines (sh9_row_<suffix>, ...); nothing else
// here has external linkage (math/fast_math.h's atan2_vec is static, so
// each unit has its own copy: no inline function built with these flags can
// be picked by the linker for another unit).
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

// Lanes as GCC vectors of 8 doubles (zmm on AVX-512, whose 32 registers
// hold the 18 sums; plain arrays spilled them on every pixel), lane l the
// columns x0 + l as before, so every version adds the same products in the
// same order (only FMA rounding differs between instruction sets).
void IBLBAKE_ROW_KERNEL(sh9_row)(const float* row, int width, const double* const* wl, double (*t)[6]) {
    constexpr int kLanes8 = 8;  // independent partial sums, one vector of doubles on AVX-512
    typedef double V8d __attribute__((vector_size(64)));
    typedef float V8f __attribute__((vector_size(32)));
    typedef int V8i __attribute__((vector_size(32)));
    V8d acc[3][6];
    for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 6; ++k) acc[c][k] = V8d{};
    const int whole = width / kLanes8 * kLanes8;
    for (int x0 = 0; x0 < whole; x0 += kLanes8) {
        // Eight RGB pixels, 24 floats, into one vector per channel.
        V8f a, b, c3;
        std::memcpy(&a, row + size_t(x0) * 3, sizeof(a));
        std::memcpy(&b, row + size_t(x0) * 3 + 8, sizeof(b));
        std::memcpy(&c3, row + size_t(x0) * 3 + 16, sizeof(c3));
        const V8f r = __builtin_shuffle(__builtin_shuffle(a, b, V8i{0, 3, 6, 9, 12, 15, 0, 0}), c3,
                                        V8i{0, 1, 2, 3, 4, 5, 10, 13});
        const V8f g = __builtin_shuffle(__builtin_shuffle(a, b, V8i{1, 4, 7, 10, 13, 0, 0, 0}), c3,
                                        V8i{0, 1, 2, 3, 4, 8, 11, 14});
        const V8f bl = __builtin_shuffle(__builtin_shuffle(a, b, V8i{2, 5, 8, 11, 14, 0, 0, 0}), c3,
                                         V8i{0, 1, 2, 3, 4, 9, 12, 15});
        const V8d v[3] = {__builtin_convertvector(r, V8d), __builtin_convertvector(g, V8d),
                          __builtin_convertvector(bl, V8d)};
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
