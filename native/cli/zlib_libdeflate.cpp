// zlib's one-shot compress2 / compress / uncompress, done by libdeflate
// (Debian's libdeflate), for the programs that link this file: the CLI and
// the tests.
//
// Why: OpenEXR 3.1 (Debian 12 and 13) compresses every ZIP chunk with
// zlib's compress2 and inflates with uncompress. Those calls were 13 % of
// the CPU time of a default bake (writing the crosses, reading a DWAB or
// ZIP source). libdeflate writes and reads the same zlib streams (RFC 1950)
// two to three times as fast, and at level 1 its output is a few per cent
// smaller. An executable's definition of a symbol comes first in the
// dynamic linker's search order, so OpenEXR's unversioned references bind
// here; nothing else changes (libpng's streaming deflate is not one of
// these). OpenEXR 3.2 and later use libdeflate themselves and no longer
// call these: there the file is inert. The Python module does not link it
// (inside Blender, whose process has bound zlib's already, it could not
// take effect).
//
// Every call that libdeflate does not complete (an output buffer too small
// for its bound, damaged input, level 0) is handed to zlib's own function
// (dlsym RTLD_NEXT), so results and error codes are zlib's wherever they
// differ. The compressors and decompressors are the library's, one per
// thread (iblbake/io/deflate.h).
#include "iblbake/io/deflate.h"

#include <dlfcn.h>
#include <libdeflate.h>
#include <zlib.h>

namespace {

template <typename Fn>
Fn zlib_own(const char* name) {
    return reinterpret_cast<Fn>(dlsym(RTLD_NEXT, name));
}

using Compress2Fn = int (*)(Bytef*, uLongf*, const Bytef*, uLong, int);
using UncompressFn = int (*)(Bytef*, uLongf*, const Bytef*, uLong);

}  // namespace

extern "C" {

int compress2(Bytef* dest, uLongf* dest_len, const Bytef* source, uLong source_len, int level) {
    if (level == Z_DEFAULT_COMPRESSION) level = 6;
    if (level >= 1 && level <= 9 && dest && dest_len && (source || source_len == 0)) {
        if (libdeflate_compressor* c = iblbake::io::thread_compressor(level)) {
            const size_t n = libdeflate_zlib_compress(c, source, source_len, dest, *dest_len);
            if (n > 0) {
                *dest_len = uLongf(n);
                return Z_OK;
            }
        }
    }
    static const Compress2Fn own = zlib_own<Compress2Fn>("compress2");
    return own ? own(dest, dest_len, source, source_len, level) : Z_STREAM_ERROR;
}

int compress(Bytef* dest, uLongf* dest_len, const Bytef* source, uLong source_len) {
    return compress2(dest, dest_len, source, source_len, Z_DEFAULT_COMPRESSION);
}

int uncompress(Bytef* dest, uLongf* dest_len, const Bytef* source, uLong source_len) {
    if (dest && dest_len && *dest_len > 0 && source) {
        if (libdeflate_decompressor* d = iblbake::io::thread_decompressor()) {
            size_t out = 0;
            if (libdeflate_zlib_decompress(d, source, source_len, dest, *dest_len, &out) == LIBDEFLATE_SUCCESS) {
                *dest_len = uLongf(out);
                return Z_OK;
            }
        }
    }
    static const UncompressFn own = zlib_own<UncompressFn>("uncompress");
    return own ? own(dest, dest_len, source, source_len) : Z_STREAM_ERROR;
}

}  // extern "C"
