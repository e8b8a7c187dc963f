#include "iblbake/io/hash.h"
#include "iblbake/io/open_regular.h"

#include <openssl/evp.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
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

namespace {
FileStamp stamp_from(const struct stat& st) {
    FileStamp s;
    s.dev = uint64_t(st.st_dev);
    s.ino = uint64_t(st.st_ino);
    s.size = int64_t(st.st_size);
    s.mtime_ns = int64_t(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
    s.ctime_ns = int64_t(st.st_ctim.tv_sec) * 1000000000 + st.st_ctim.tv_nsec;
    return s;
}

int64_t now_ns() {
    struct timespec t {};
    ::clock_gettime(CLOCK_REALTIME, &t);
    return int64_t(t.tv_sec) * 1000000000 + t.tv_nsec;
}

// A change this close before the hashing began may share the clock tick
// (file times come from the kernel's coarse clock, a few ms a tick) of a
// later change that would then leave the stamp unchanged.
constexpr int64_t kRacyNs = 100000000;  // 0.1 s

// The sha256 of the open file fd (from where it stands to its end).
std::string hash_fd(int fd, const std::string& path) {
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

struct Fd {
    int fd;
    ~Fd() { ::close(fd); }
};

// Opened without blocking and checked before any read: a FIFO (whose
// open would wait for a writer) or a device (/dev/zero never ends) is
// refused at once. Bakes hash their source beside its decoding, before
// the reader has said what the path is.
int open_to_hash(const std::string& path) {
    const int fd = open_regular_file(path);
    if (fd < 0) throw std::runtime_error("cannot hash '" + path + "': not a readable regular file");
    return fd;
}
}  // namespace

std::optional<FileStamp> stamp_of(const std::string& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return std::nullopt;
    return stamp_from(st);
}

std::string sha256_file(const std::string& path) {
    const Fd f{open_to_hash(path)};
    return hash_fd(f.fd, path);
}

FileDigest sha256_file_stamped(const std::string& path) {
    const int64_t began = now_ns();
    const Fd f{open_to_hash(path)};
    struct stat before {}, after {};
    const bool stat_before = ::fstat(f.fd, &before) == 0;
    FileDigest out;
    out.sha256 = hash_fd(f.fd, path);
    if (stat_before && ::fstat(f.fd, &after) == 0) {
        const FileStamp a = stamp_from(before), b = stamp_from(after);
        if (a == b && std::max(a.mtime_ns, a.ctime_ns) < began - kRacyNs) out.stamp = a;
    }
    return out;
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
