#include "iblbake/io/deflate.h"

#include <libdeflate.h>

#include <memory>

namespace iblbake::io {

namespace {
struct CompressorFree {
    void operator()(libdeflate_compressor* c) const { libdeflate_free_compressor(c); }
};
struct DecompressorFree {
    void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};
}  // namespace

libdeflate_compressor* thread_compressor(int level) {
    if (level < 1 || level > 12) return nullptr;
    thread_local std::unique_ptr<libdeflate_compressor, CompressorFree> per_level[13];
    auto& c = per_level[level];
    if (!c) c.reset(libdeflate_alloc_compressor(level));
    return c.get();
}

libdeflate_decompressor* thread_decompressor() {
    thread_local std::unique_ptr<libdeflate_decompressor, DecompressorFree> d;
    if (!d) d.reset(libdeflate_alloc_decompressor());
    return d.get();
}

}  // namespace iblbake::io
