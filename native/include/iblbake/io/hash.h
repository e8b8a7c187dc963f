// SHA-256 (OpenSSL) of files and memory, as lowercase hex.
#pragma once
#include <cstddef>
#include <string>

namespace iblbake::io {
std::string sha256_file(const std::string& path);
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
