// util: generic helpers below every other room (they know no image, no
// integrator, no file). Here the one parallel-for for the whole library
// (TBB). Work items are independent and each writes its own outputs, so
// results never depend on thread count.
#pragma once
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace iblbake {

template <typename Fn>
void parallel_for(int begin, int end, Fn&& fn) {
    if (end <= begin) return;
    tbb::parallel_for(tbb::blocked_range<int>(begin, end), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i != r.end(); ++i) fn(i);
    });
}

}  // namespace iblbake
