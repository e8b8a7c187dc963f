#include "iblbake/io/hash.h"

#include <openssl/evp.h>

#include <fstream>
#include <memory>
#include <stdexcept>
#include <vector>

namespace iblbake::io {

namespace {
struct Digest {
    std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx{EVP_MD_CTX_new(), EVP_MD_CTX_free};
    Digest() {
        if (!ctx || EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr) != 1)
            throw std::runtime_error("sha256: OpenSSL init failed");
    }
    void update(const void* p, size_t n) { EVP_DigestUpdate(ctx.get(), p, n); }
    std::string hex() {
        unsigned char md[EVP_MAX_MD_SIZE];
        unsigned int len = 0;
        EVP_DigestFinal_ex(ctx.get(), md, &len);
        static const char* digits = "0123456789abcdef";
        std::string s;
        for (unsigned i = 0; i < len; ++i) { s += digits[md[i] >> 4]; s += digits[md[i] & 15]; }
        return s;
    }
};
}  // namespace

std::string sha256_file(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw std::runtime_error("cannot read '" + path + "' to hash it");
    Digest d;
    // 128 KB at a time, not zeroed first: files are hashed while a bake is at
    // its largest (beside the reading of its source, in the writer's tasks).
    constexpr size_t kChunk = size_t(1) << 17;
    const std::unique_ptr<char[]> buf(new char[kChunk]);
    while (f) {
        f.read(buf.get(), std::streamsize(kChunk));
        d.update(buf.get(), size_t(f.gcount()));
    }
    return d.hex();
}

std::string sha256_bytes(const void* data, size_t size) {
    Digest d;
    d.update(data, size);
    return d.hex();
}

}  // namespace iblbake::io
