#include "iblbake/image/image.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "iblbake/util/parallel.h"

#if defined(__unix__) || defined(__APPLE__)
#include <sys/mman.h>
#include <unistd.h>
#define IBLBAKE_HAVE_MADVISE 1
#endif

namespace iblbake {

RowRelease::RowRelease(Image& img) : img_(img) {
#ifdef IBLBAKE_HAVE_MADVISE
    const size_t page = size_t(sysconf(_SC_PAGESIZE));
    const auto base = reinterpret_cast<uintptr_t>(img.pixels.data());
    first_ = size_t((base + page - 1) / page * page - base);
#endif
}

void RowRelease::before(int y) {
#ifdef IBLBAKE_HAVE_MADVISE
    if (img_.pixels.empty()) return;
    const size_t page = size_t(sysconf(_SC_PAGESIZE));
    y = std::clamp(y, 0, img_.height);
    const size_t end = size_t(y) * size_t(img_.width) * 3 * sizeof(float);  // the rows above y, bytes
    if (end <= first_) return;
    const size_t upto = (end - first_) / page * page;  // whole pages from the first
    if (upto <= done_) return;
    char* base = reinterpret_cast<char*>(img_.pixels.data()) + first_;
    // (A failure leaves the pages held: nothing is lost but the saving.)
    if (madvise(base + done_, upto - done_, MADV_DONTNEED) == 0) bytes_ += upto - done_;
    done_ = upto;
#else
    (void)y;
#endif
}

void zero_fill(float* p, size_t n) {
    constexpr size_t kChunk = size_t(1) << 18;  // 1 MB of floats per task
    if (n <= kChunk) {
        if (n) std::memset(p, 0, n * sizeof(float));
        return;
    }
    const int chunks = int((n + kChunk - 1) / kChunk);
    parallel_for(0, chunks, [&](int c) {
        const size_t b = size_t(c) * kChunk, e = std::min(n, b + kChunk);
        std::memset(p + b, 0, (e - b) * sizeof(float));
    });
}

namespace {

constexpr size_t kBlock = size_t(1) << 16;  // floats checked per task

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define IBLBAKE_SCAN_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define IBLBAKE_SCAN_CLONES
#endif

// The largest of the values' bits with the sign cleared: with the sign gone
// a float's bits order as its magnitude does, infinity above every finite
// value and NaN above infinity. One unsigned max over the block, no early
// exit, which the compiler vectorises (the version for the CPU picked when
// the program loads).
IBLBAKE_SCAN_CLONES uint32_t max_magnitude_bits(const float* p, size_t n) {
    uint32_t top = 0;
    for (size_t k = 0; k < n; ++k) {
        uint32_t u;
        std::memcpy(&u, p + k, sizeof(u));
        top = std::max(top, u & 0x7fffffffu);
    }
    return top;
}

// Whether some value's magnitude bits exceed `limit`: blocks on every core.
bool any_magnitude_above(const float* p, size_t n, uint32_t limit) {
    if (n <= kBlock) return max_magnitude_bits(p, n) > limit;
    const int blocks = int((n + kBlock - 1) / kBlock);
    std::atomic<bool> found{false};
    parallel_for(0, blocks, [&](int c) {
        if (found.load(std::memory_order_relaxed)) return;
        const size_t b = size_t(c) * kBlock, e = std::min(n, b + kBlock);
        if (max_magnitude_bits(p + b, e - b) > limit) found.store(true, std::memory_order_relaxed);
    });
    return found.load();
}

}  // namespace

bool all_finite(FloatSpan v) {
    // Exponent all ones (infinite or NaN) is magnitude bits >= 0x7f800000.
    return !any_magnitude_above(v.data, v.size, 0x7f7fffffu);
}

bool any_beyond(FloatSpan v, float max_abs) {
    // NaN is beyond any bound; so is every value when the bound is negative or NaN.
    if (!(max_abs >= 0.0f)) return v.size > 0;
    uint32_t limit;
    std::memcpy(&limit, &max_abs, sizeof(limit));  // +inf: only NaN is beyond
    return any_magnitude_above(v.data, v.size, limit);
}

}  // namespace iblbake
