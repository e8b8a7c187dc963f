// The SH9 projection's row sums, mip 0's lat-long coordinates and the
// irradiance's cosine sums (specular_kernel.h), included by one translation
// unit per instruction set (specular_kernel_*.cpp) with IBLBAKE_ISA_SUFFIX
// naming the functions it defines (sh9_row_<suffix>, ...); nothing else
// here has external linkage (atan2 is this file's own copy of
// math/fast_math.h's atan2_vec, so no inline function built with these
// flags can be picked by the linker for another unit).
#include <cmath>
#include <cstddef>

#include "specular_kernel.h"

#define IBLBAKE_ROW_KERNEL_CAT(a, b) a##_##b
#define IBLBAKE_ROW_KERNEL_NAME(a, b) IBLBAKE_ROW_KERNEL_CAT(a, b)
#define IBLBAKE_ROW_KERNEL(name) IBLBAKE_ROW_KERNEL_NAME(name, IBLBAKE_ISA_SUFFIX)

namespace iblbake {
namespace kernel {

void IBLBAKE_ROW_KERNEL(sh9_row)(const float* row, int width, const double* const* wl, double (*t)[6]) {
    constexpr int kLanes8 = 8;  // independent partial sums, one vector of doubles on AVX-512
    double acc[3][6][kLanes8] = {};
    const int whole = width / kLanes8 * kLanes8;
    for (int x0 = 0; x0 < whole; x0 += kLanes8)
        for (int l = 0; l < kLanes8; ++l) {
            const float* px = row + size_t(x0 + l) * 3;
            for (int c = 0; c < 3; ++c) {
                const double v = px[c];
                for (int k = 0; k < 6; ++k) acc[c][k][l] += v * wl[k][x0 + l];
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

namespace {

double atan2_row(double y, double x) {
    const double ax = std::fabs(x), ay = std::fabs(y);
    const double hi = ax > ay ? ax : ay, lo = ax > ay ? ay : ax;
    const double a = hi > 0.0 ? lo / hi : 0.0;
    const bool mid = a > 0.66;
    const double t = mid ? (a - 1.0) / (a + 1.0) : a;
    const double z = t * t;
    const double p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z - 7.500855792314704667340e1) * z -
                      1.228866684490136173410e2) * z - 6.485021904942025371773e1;
    const double q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z + 4.328810604912902668951e2) *
                      z + 4.853903996359136964868e2) * z + 1.945506571482613964425e2;
    double r = t + t * z * p / q;
    r += mid ? 0.78539816339744830962 + 0.5 * 6.123233995736765886130e-17 : 0.0;
    r = ay > ax ? 1.57079632679489661923 - r : r;
    r = x < 0.0 ? 3.14159265358979323846 - r : r;
    return y < 0.0 ? -r : r;
}

}  // namespace

void IBLBAKE_ROW_KERNEL(mirror_row)(const double* frame, double b, int n, int w, int h, double* fx, double* fy) {
    constexpr double kPiD = 3.14159265358979323846;
    for (int i = 0; i < n; ++i) {
        const double a = 2.0 * (i + 0.5) / n - 1.0;
        const double ex = frame[0] + frame[3] * a + frame[6] * b, ey = frame[1] + frame[4] * a + frame[7] * b,
                     ez = frame[2] + frame[5] * a + frame[8] * b;
        // Blender (x, y, z) = (ex, -ez, ey); the length cancels in both angles.
        const double bx = ex, by = -ez, bz = ey;
        const double u = 0.5 - atan2_row(by, bx) * (0.5 / kPiD);
        const double v = 0.5 + atan2_row(bz, std::sqrt(bx * bx + by * by)) * (1.0 / kPiD);
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
