// SHA-256 (OpenSSL) of files and memory, as lowercase hex.
#pragma once
#include <cstddef>
#include <string>

namespace iblbake::io {
std::string sha256_file(const std::string& path);
std::string sha256_bytes(const void* data, size_t size);
}  // namespace iblbake::io
