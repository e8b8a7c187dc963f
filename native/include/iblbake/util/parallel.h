// util: generic helpers below every other room (they know no image, no
// integrator, no file). Here the one parallel-for for the whole library
// (TBB). Work items are independent and each writes its own outputs, so
// results never depend on thread count.
#pragma once
#include <algorithm>
#include <atomic>
#include <mutex>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace iblbake {

template <typename Fn>
void parallel_for(int begin, int end, Fn&& fn) {
    if (end <= begin) return;
    tbb::parallel_for(tbb::blocked_range<int>(begin, end), [&](const tbb::blocked_range<int>& r) {
        for (int i = r.begin(); i != r.end(); ++i) fn(i);
    });
}

// parallel_for whose indices are handed out in increasing order (each core
// takes the next one left), for a loop whose finished items let go of what
// no later item reads: frontier(k) is called, one call at a time and k
// increasing, each time every index below k has finished (the last call
// with k = end). Results are those of parallel_for: only the order differs.
template <typename Fn, typename Frontier>
void parallel_for_ordered(int begin, int end, Fn&& fn, Frontier&& frontier) {
    if (end <= begin) return;
    std::atomic<int> next{begin};
    std::mutex m;
    std::vector<char> finished(size_t(end - begin), 0);
    int low = begin;  // every index below has finished
    const int workers = std::max(1, std::min(end - begin, tbb::this_task_arena::max_concurrency()));
    tbb::parallel_for(0, workers, [&](int) {
        for (int i; (i = next.fetch_add(1)) < end;) {
            fn(i);
            const std::lock_guard<std::mutex> lock(m);
            finished[size_t(i - begin)] = 1;
            const int was = low;
            while (low < end && finished[size_t(low - begin)]) ++low;
            if (low != was) frontier(low);
        }
    });
}

}  // namespace iblbake
