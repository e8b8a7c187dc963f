#include "iblbake/image/image.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "iblbake/ibl/parallel.h"

namespace iblbake {

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

// True when the predicate holds for some value of [b, e): an OR over the
// block with no early exit, which the compiler vectorises.
template <typename Pred>
bool any_in(const float* p, size_t n, Pred pred) {
    if (n <= kBlock) {
        bool any = false;
        for (size_t k = 0; k < n; ++k) any |= pred(p[k]);
        return any;
    }
    const int blocks = int((n + kBlock - 1) / kBlock);
    std::atomic<bool> found{false};
    parallel_for(0, blocks, [&](int c) {
        if (found.load(std::memory_order_relaxed)) return;
        const size_t b = size_t(c) * kBlock, e = std::min(n, b + kBlock);
        bool any = false;
        for (size_t k = b; k < e; ++k) any |= pred(p[k]);
        if (any) found.store(true, std::memory_order_relaxed);
    });
    return found.load();
}

}  // namespace

bool all_finite(FloatSpan v) {
    // Exponent all ones: infinite or NaN.
    return !any_in(v.data, v.size, [](float x) {
        uint32_t u;
        std::memcpy(&u, &x, 4);
        return (u & 0x7f800000u) == 0x7f800000u;
    });
}

bool any_beyond(FloatSpan v, float max_abs) {
    return any_in(v.data, v.size, [max_abs](float x) { return !(std::fabs(x) <= max_abs); });
}

}  // namespace iblbake
