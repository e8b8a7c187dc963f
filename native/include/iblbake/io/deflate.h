// libdeflate's compressors and decompressors, one per thread (they are not
// shareable), made on first use and freed when the thread ends: for the EXR
// ZIP blocks the reader inflates itself (exr_file.cpp) and for the CLI's
// stand-ins for zlib's one-shot calls (cli/zlib_libdeflate.cpp).
#pragma once

struct libdeflate_compressor;
struct libdeflate_decompressor;

namespace iblbake::io {

// This thread's compressor at `level` (1..12, libdeflate's levels), or null
// when libdeflate cannot make one (out of memory, or a level it refuses).
libdeflate_compressor* thread_compressor(int level);
// This thread's decompressor, or null when libdeflate cannot make one.
libdeflate_decompressor* thread_decompressor();

}  // namespace iblbake::io
