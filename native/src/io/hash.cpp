#include "iblbake/io/hash.h"
#include "iblbake/io/open_regular.h"

#include <openssl/evp.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
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
    // Opened without blocking and checked before any read: a FIFO (whose
    // open would wait for a writer) or a device (/dev/zero never ends) is
    // refused at once. Bakes hash their source beside its decoding, before
    // the reader has said what the path is.
    const int fd = open_regular_file(path);
    if (fd < 0) throw std::runtime_error("cannot hash '" + path + "': not a readable regular file");
    struct Closer {
        int fd;
        ~Closer() { ::close(fd); }
    } closer{fd};
    Digest d;
    // 128 KB at a time, not zeroed first: files are hashed while a bake is at
    // its largest (beside the reading of its source, in the writer's tasks).
    constexpr size_t kChunk = size_t(1) << 17;
    const std::unique_ptr<char[]> buf(new char[kChunk]);
    for (;;) {
        const ssize_t got = ::read(fd, buf.get(), kChunk);
        if (got < 0) {
            if (errno == EINTR) continue;
            throw std::runtime_error("cannot read '" + path + "' to hash it");
        }
        if (got == 0) break;
        d.update(buf.get(), size_t(got));
    }
    return d.hex();
}

std::string sha256_bytes(const void* data, size_t size) {
    Digest d;
    d.update(data, size);
    return d.hex();
}

Sha256::Sha256() : ctx_(new Digest) {}
Sha256::~Sha256() { delete static_cast<Digest*>(ctx_); }
void Sha256::update(const void* data, size_t size) { static_cast<Digest*>(ctx_)->update(data, size); }
std::string Sha256::hex() { return static_cast<Digest*>(ctx_)->hex(); }

}  // namespace iblbake::io
