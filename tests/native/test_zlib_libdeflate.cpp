// native/cli/zlib_libdeflate.cpp: zlib's one-shot calls through libdeflate.
// Checked against zlib's own streaming inflate and deflate (which the file
// does not replace): what ours writes, zlib reads; what zlib writes, ours
// reads; and where ours cannot finish, zlib's own answer comes back.
#include <gtest/gtest.h>
#include <dlfcn.h>
#include <zlib.h>

#include <cstdint>
#include <random>
#include <vector>

namespace {

// Half-float-like bytes: compressible but not trivially.
std::vector<unsigned char> sample_bytes(size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::vector<unsigned char> v(n);
    for (size_t i = 0; i < n; ++i) v[i] = (i % 2) ? 0x3c : static_cast<unsigned char>(rng() % 23);
    return v;
}

std::vector<unsigned char> zlib_inflate(const unsigned char* data, size_t n, size_t expect) {
    std::vector<unsigned char> out(expect + 16);
    z_stream s{};
    EXPECT_EQ(inflateInit(&s), Z_OK);
    s.next_in = const_cast<unsigned char*>(data);
    s.avail_in = uInt(n);
    s.next_out = out.data();
    s.avail_out = uInt(out.size());
    EXPECT_EQ(inflate(&s, Z_FINISH), Z_STREAM_END);
    out.resize(s.total_out);
    inflateEnd(&s);
    return out;
}

std::vector<unsigned char> zlib_deflate(const std::vector<unsigned char>& in, int level) {
    std::vector<unsigned char> out(compressBound(uLong(in.size())));
    z_stream s{};
    EXPECT_EQ(deflateInit(&s, level), Z_OK);
    s.next_in = const_cast<unsigned char*>(in.data());
    s.avail_in = uInt(in.size());
    s.next_out = out.data();
    s.avail_out = uInt(out.size());
    EXPECT_EQ(deflate(&s, Z_FINISH), Z_STREAM_END);
    out.resize(s.total_out);
    deflateEnd(&s);
    return out;
}

}  // namespace

TEST(ZlibLibdeflate, TheProgramsCompress2IsOurs) {
    // The definition the dynamic linker binds (OpenEXR's references too) is
    // this executable's, not libz's.
    Dl_info own{}, main_exe{};
    ASSERT_TRUE(dladdr(reinterpret_cast<void*>(&compress2), &own));
    ASSERT_TRUE(dladdr(reinterpret_cast<void*>(&zlib_inflate), &main_exe));
    EXPECT_STREQ(own.dli_fname, main_exe.dli_fname);
    void* global = dlsym(RTLD_DEFAULT, "compress2");
    EXPECT_EQ(global, reinterpret_cast<void*>(&compress2));
}

TEST(ZlibLibdeflate, WhatItWritesZlibReads) {
    for (size_t n : {size_t(0), size_t(1), size_t(100), size_t(65536), size_t(1) << 20}) {
        const std::vector<unsigned char> in = sample_bytes(n, unsigned(n));
        for (int level : {1, 4, 6, 9, Z_DEFAULT_COMPRESSION}) {
            std::vector<unsigned char> out(compressBound(uLong(n)));
            uLongf len = uLongf(out.size());
            ASSERT_EQ(compress2(out.data(), &len, in.data(), uLong(n), level), Z_OK) << n << " " << level;
            EXPECT_EQ(zlib_inflate(out.data(), len, n), in) << n << " " << level;
        }
    }
}

TEST(ZlibLibdeflate, WhatZlibWritesItReads) {
    const std::vector<unsigned char> in = sample_bytes(300000, 7);
    for (int level : {1, 6, 9}) {
        const std::vector<unsigned char> z = zlib_deflate(in, level);
        std::vector<unsigned char> out(in.size());
        uLongf len = uLongf(out.size());
        ASSERT_EQ(uncompress(out.data(), &len, z.data(), uLong(z.size())), Z_OK);
        EXPECT_EQ(len, in.size());
        EXPECT_EQ(out, in);
        // A larger buffer than needed: the real size comes back.
        std::vector<unsigned char> big(in.size() + 1000);
        len = uLongf(big.size());
        ASSERT_EQ(uncompress(big.data(), &len, z.data(), uLong(z.size())), Z_OK);
        EXPECT_EQ(len, in.size());
    }
}

TEST(ZlibLibdeflate, FailuresAreZlibsOwn) {
    const std::vector<unsigned char> in = sample_bytes(50000, 3);
    const std::vector<unsigned char> z = zlib_deflate(in, 6);
    // Too small an output buffer: Z_BUF_ERROR, as zlib says.
    std::vector<unsigned char> small(in.size() / 2);
    uLongf len = uLongf(small.size());
    EXPECT_EQ(uncompress(small.data(), &len, z.data(), uLong(z.size())), Z_BUF_ERROR);
    // A damaged stream (its checksum): Z_DATA_ERROR.
    std::vector<unsigned char> bad = z;
    bad[bad.size() - 1] ^= 0x55;
    std::vector<unsigned char> out(in.size());
    len = uLongf(out.size());
    EXPECT_EQ(uncompress(out.data(), &len, bad.data(), uLong(bad.size())), Z_DATA_ERROR);
    // Cut short: not Z_OK.
    len = uLongf(out.size());
    EXPECT_NE(uncompress(out.data(), &len, z.data(), uLong(z.size() / 2)), Z_OK);
    // An output buffer too small for the compressed data: Z_BUF_ERROR.
    std::vector<unsigned char> tiny(10);
    len = uLongf(tiny.size());
    EXPECT_EQ(compress2(tiny.data(), &len, in.data(), uLong(in.size()), 1), Z_BUF_ERROR);
    // Level 0 (stored) is zlib's: still a stream zlib reads.
    std::vector<unsigned char> stored(compressBound(uLong(in.size())));
    len = uLongf(stored.size());
    ASSERT_EQ(compress2(stored.data(), &len, in.data(), uLong(in.size()), 0), Z_OK);
    EXPECT_EQ(zlib_inflate(stored.data(), len, in.size()), in);
}
