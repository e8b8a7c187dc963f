// SHA-256 (OpenSSL) of files and memory, as lowercase hex.
#pragma once
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace iblbake::io {
std::string sha256_file(const std::string& path);

// What tells a file's bytes have not changed without reading them again:
// its device, inode, size, and modification and status-change times in ns.
struct FileStamp {
    uint64_t dev = 0, ino = 0;
    int64_t size = 0, mtime_ns = 0, ctime_ns = 0;
    bool operator==(const FileStamp& o) const {
        return dev == o.dev && ino == o.ino && size == o.size && mtime_ns == o.mtime_ns && ctime_ns == o.ctime_ns;
    }
};
// The path's stamp (following links); none when it cannot be stat'ed.
std::optional<FileStamp> stamp_of(const std::string& path);

// A file's sha256 and the stamp it kept while it was hashed. No stamp when
// it changed meanwhile, or when it was last changed so shortly before the
// hashing began that a change within the same clock tick would leave the
// stamp as it is (git's "racy" files): such a digest is never reused.
struct FileDigest {
    std::string sha256;
    std::optional<FileStamp> stamp;
};
FileDigest sha256_file_stamped(const std::string& path);
std::string sha256_bytes(const void* data, size_t size);

// SHA-256 taken piece by piece (update as the bytes come, hex() once).
class Sha256 {
public:
    Sha256();
    ~Sha256();
    Sha256(const Sha256&) = delete;
    Sha256& operator=(const Sha256&) = delete;
    void update(const void* data, size_t size);
    std::string hex();

private:
    void* ctx_;  // OpenSSL's EVP_MD_CTX
};
}  // namespace iblbake::io
