#include "iblbake/bake/lut_cache.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <cstring>
#include <system_error>

#include "iblbake/io/hash.h"

namespace iblbake {

namespace fs = std::filesystem;

std::string lut_cache_key(int size, LutModel model, const LutQuality& q) {
    return "brdf_lut-v" + std::to_string(kLutAlgorithmVersion) + "-" + lut_model_name(model) + "-" +
           std::to_string(size) + "-p" + std::to_string(q.phi_points) + "-u" + std::to_string(q.u_points) +
           (q.row_nodes >= 4 && q.row_nodes < size ? "-k" + std::to_string(q.row_nodes) : "");
}

namespace {

// A temporary file's tag, unique to this process and call: bakes running
// side by side in one process (the CLI's --jobs) may store the same entry.
std::string tmp_tag() {
    static std::atomic<unsigned> counter{0};
    return std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

// Entry layout: 8-byte magic, width and height (int32, this machine's
// byte order, as the magic's last byte records), the payload's sha256
// (64 hex digits), then width * height * 3 float32. Read back with one fread: a
// warm LUT costs about a millisecond, where decoding a zip EXR of it took
// 37 ms. An entry whose payload does not match its checksum, or holds a
// value that is not finite, is a miss: the table is made again and the
// entry overwritten (the cache is shared by every bake on the machine, so
// one damaged file must not poison them).
constexpr char kMagic[8] = {'I', 'B', 'L', 'L', 'U', 'T', '2', char(sizeof(int) * 16 + sizeof(float))};

std::string payload_digest(const Image& img) {
    return io::sha256_bytes(img.pixels.data(), img.pixels.size() * sizeof(float));
}

struct File {
    std::FILE* f;
    ~File() {
        if (f) std::fclose(f);
    }
};

}  // namespace

std::optional<Image> FileLutCache::load(const std::string& key) {
    const fs::path p = dir_ / (key + ".lut");
    File file{std::fopen(p.c_str(), "rb")};
    if (!file.f) return std::nullopt;
    char magic[8];
    int32_t wh[2];
    if (std::fread(magic, 1, 8, file.f) != 8 || std::memcmp(magic, kMagic, 8) != 0) return std::nullopt;
    if (std::fread(wh, sizeof(int32_t), 2, file.f) != 2 || wh[0] < 1 || wh[1] < 1 || wh[0] > 65536 || wh[1] > 65536)
        return std::nullopt;
    char digest[65] = {0};
    if (std::fread(digest, 1, 64, file.f) != 64) return std::nullopt;
    Image lut(wh[0], wh[1], Uninitialized{});  // read whole below, or a miss
    if (std::fread(lut.pixels.data(), sizeof(float), lut.pixels.size(), file.f) != lut.pixels.size())
        return std::nullopt;  // truncated: a miss, and store() replaces it
    char extra;
    if (std::fread(&extra, 1, 1, file.f) != 0) return std::nullopt;  // too long: not what we wrote
    if (!all_finite(lut.pixels)) return std::nullopt;
    if (payload_digest(lut) != std::string(digest, 64)) return std::nullopt;  // damaged
    return lut;
}

void FileLutCache::store(const std::string& key, const Image& lut) {
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) return;  // a cache that cannot be written is not an error
    const fs::path final_path = dir_ / (key + ".lut");
    const fs::path tmp = dir_ / (key + ".tmp-" + tmp_tag() + ".lut");
    bool ok = false;
    {
        File file{std::fopen(tmp.c_str(), "wb")};
        const int32_t wh[2] = {lut.width, lut.height};
        const std::string digest = payload_digest(lut);
        ok = file.f && std::fwrite(kMagic, 1, 8, file.f) == 8 && std::fwrite(wh, sizeof(int32_t), 2, file.f) == 2 &&
             std::fwrite(digest.data(), 1, 64, file.f) == 64 &&
             std::fwrite(lut.pixels.data(), sizeof(float), lut.pixels.size(), file.f) == lut.pixels.size() &&
             std::fflush(file.f) == 0;
    }
    if (ok) fs::rename(tmp, final_path, ec);
    fs::remove(tmp, ec);
}

std::string encoded_lut_key(const Image& lut, const std::string& encoding) {
    return "brdf_lut-file-" + payload_digest(lut) + "-" + encoding;
}

namespace {

constexpr char kEncodedMagic[8] = {'I', 'B', 'L', 'L', 'U', 'T', 'F', '1'};

// The whole file, or nothing (missing, unreadable or larger than `limit`).
std::optional<std::string> read_all(const fs::path& p, uintmax_t limit) {
    std::error_code ec;
    const uintmax_t size = fs::file_size(p, ec);
    if (ec || size > limit) return std::nullopt;
    File file{std::fopen(p.c_str(), "rb")};
    if (!file.f) return std::nullopt;
    std::string bytes(size_t(size), '\0');
    if (std::fread(bytes.data(), 1, bytes.size(), file.f) != bytes.size()) return std::nullopt;
    char extra;
    if (std::fread(&extra, 1, 1, file.f) != 0) return std::nullopt;  // grew while read
    return bytes;
}

bool write_all(const fs::path& p, const char* data, size_t size) {
    File file{std::fopen(p.c_str(), "wb")};
    return file.f && std::fwrite(data, 1, size, file.f) == size && std::fflush(file.f) == 0;
}

constexpr uintmax_t kMaxEncoded = uintmax_t(1) << 30;  // a 4096^2 float LUT is 200 MB

}  // namespace

bool FileLutCache::copy_encoded(const std::string& key, const fs::path& to, std::string* sha256) {
    const std::optional<std::string> entry = read_all(dir_ / (key + ".enc"), kMaxEncoded + 72);
    if (!entry || entry->size() < 72 || std::memcmp(entry->data(), kEncodedMagic, 8) != 0) return false;
    const char* bytes = entry->data() + 72;
    const size_t size = entry->size() - 72;
    std::string digest = io::sha256_bytes(bytes, size);
    if (digest != entry->substr(8, 64)) return false;  // damaged
    if (write_all(to, bytes, size)) {
        if (sha256) *sha256 = std::move(digest);
        return true;
    }
    std::error_code ec;
    fs::remove(to, ec);  // the caller writes it itself
    return false;
}

void FileLutCache::store_encoded(const std::string& key, const fs::path& from) {
    const std::optional<std::string> bytes = read_all(from, kMaxEncoded);
    if (!bytes) return;
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) return;  // a cache that cannot be written is not an error
    std::string entry(kEncodedMagic, 8);
    entry += io::sha256_bytes(bytes->data(), bytes->size());
    entry += *bytes;
    const fs::path tmp = dir_ / (key + ".tmp-" + tmp_tag() + ".enc");
    if (write_all(tmp, entry.data(), entry.size())) fs::rename(tmp, dir_ / (key + ".enc"), ec);
    fs::remove(tmp, ec);
}

fs::path FileLutCache::default_dir() {
    if (const char* d = std::getenv("IBLBAKE_CACHE_DIR"); d && *d) return d;
    if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return fs::path(x) / "iblbake";
    if (const char* h = std::getenv("HOME"); h && *h) return fs::path(h) / ".cache" / "iblbake";
    return fs::temp_directory_path() / "iblbake-cache";
}

}  // namespace iblbake
