#include "iblbake/math/half.h"

#include <Imath/half.h>

#include <cstring>

#if defined(__x86_64__)
#include <cpuid.h>
#include <immintrin.h>
#endif

namespace iblbake {

namespace {

#if defined(__x86_64__)
__attribute__((target("avx,f16c"))) void floats_to_half_f16c(const float* in, uint16_t* out, size_t n) {
    size_t k = 0;
    for (; k + 8 <= n; k += 8)
        _mm_storeu_si128(reinterpret_cast<__m128i*>(out + k),
                         _mm256_cvtps_ph(_mm256_loadu_ps(in + k), _MM_FROUND_TO_NEAREST_INT));
    for (; k < n; ++k) out[k] = _cvtss_sh(in[k], _MM_FROUND_TO_NEAREST_INT);
}

// In order, 8 at a time: the 8 values read (16 bytes at 2 n + 2 k in the
// in-place case) before their floats are written (32 bytes at 4 k, which end
// at or before the next 8 values' bytes while k + 8 <= n); bytes through
// memcpy, so the overlap is no aliasing question.
__attribute__((target("avx,f16c"))) void halves_to_floats_f16c(const unsigned char* in, float* out, size_t n) {
    size_t k = 0;
    for (; k + 8 <= n; k += 8) {
        const __m256 v = _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(in + 2 * k)));
        _mm256_storeu_ps(out + k, v);
    }
    for (; k < n; ++k) {
        uint16_t h;
        std::memcpy(&h, in + 2 * k, sizeof(h));
        const float f = _cvtsh_ss(h);
        std::memcpy(out + k, &f, sizeof(f));
    }
}

__attribute__((target("f16c"))) uint16_t float_to_half_f16c(float v) { return _cvtss_sh(v, _MM_FROUND_TO_NEAREST_INT); }

// CPUID leaf 1 (ECX: OSXSAVE bit 27, AVX 28, F16C 29) and XCR0 (the OS saves
// XMM and YMM state), as __builtin_cpu_supports("avx") checks; read by hand
// because GCC 10 (the wheels' Debian 11 build) has no "f16c" for that builtin.
bool has_f16c() {
    static const bool f16c = [] {
        unsigned a = 0, b = 0, c = 0, d = 0;
        if (!__get_cpuid(1, &a, &b, &c, &d)) return false;
        const unsigned need = (1u << 27) | (1u << 28) | (1u << 29);
        if ((c & need) != need) return false;
        unsigned lo = 0, hi = 0;
        __asm__("xgetbv" : "=a"(lo), "=d"(hi) : "c"(0));
        return (lo & 6u) == 6u;
    }();
    return f16c;
}
#endif

}  // namespace

uint16_t float_to_half(float v) {
#if defined(__x86_64__)
    if (has_f16c()) return float_to_half_f16c(v);
#endif
    return Imath::half(v).bits();
}

void floats_to_half(const float* in, uint16_t* out, size_t n) {
#if defined(__x86_64__)
    if (has_f16c()) {
        floats_to_half_f16c(in, out, n);
        return;
    }
#endif
    for (size_t k = 0; k < n; ++k) out[k] = Imath::half(in[k]).bits();
}

void detail::halves_to_floats_software(const void* in, float* out, size_t n) {
    const unsigned char* bytes = static_cast<const unsigned char*>(in);
    for (size_t k = 0; k < n; ++k) {
        uint16_t bits;
        std::memcpy(&bits, bytes + 2 * k, sizeof(bits));
        Imath::half h;
        h.setBits(bits);
        const float f = float(h);
        std::memcpy(out + k, &f, sizeof(f));
    }
}

void halves_to_floats(const void* in, float* out, size_t n) {
#if defined(__x86_64__)
    if (has_f16c()) {
        halves_to_floats_f16c(static_cast<const unsigned char*>(in), out, n);
        return;
    }
#endif
    detail::halves_to_floats_software(in, out, n);
}

}  // namespace iblbake
