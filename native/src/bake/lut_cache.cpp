#include "iblbake/bake/lut_cache.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <cstring>
#include <memory>
#include <system_error>

#include "iblbake/io/hash.h"
#include "iblbake/io/open_regular.h"

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

// Entry layout (<key>.lut): 8-byte magic, width and height (int32, this
// machine's byte order, as the magic's last byte records), the checksum
// (64 hex digits), the key's length (uint32) and the key, then
// width * height * 3 float32. The checksum is the sha256 of the key and the
// payload's sha256: an intact entry under another entry's name (caches are
// synced, restored, copied) is a miss, not another LUT. Read back with one
// fread: a warm LUT costs about a millisecond, where decoding a zip EXR of
// it took 37 ms. An entry whose key or payload does not match its checksum,
// or holds a value that is not finite, is a miss: the table is made again
// and the entry overwritten (the cache is shared by every bake on the
// machine, so one damaged or misnamed file must not poison them).
constexpr char kMagic[8] = {'I', 'B', 'L', 'L', 'U', 'T', '3', char(sizeof(int) * 16 + sizeof(float))};
constexpr uint32_t kMaxKey = 1024;

// The checksum of an entry whose payload's sha256 is `payload_sha256`.
std::string entry_digest(const std::string& key, const std::string& payload_sha256) {
    const std::string keyed = key + '\n' + payload_sha256;
    return io::sha256_bytes(keyed.data(), keyed.size());
}

struct File {
    std::FILE* f;
    ~File() {
        if (f) std::fclose(f);
    }
};

// A cache entry, opened only when it is a regular file: without blocking (a
// FIFO named like an entry would hang every bake that needs it) and without
// following a symbolic link. nullptr: a miss.
std::FILE* open_entry(const fs::path& p) {
    const int fd = io::open_regular_file(p.string(), false);
    if (fd < 0) return nullptr;
    std::FILE* f = ::fdopen(fd, "rb");
    if (!f) ::close(fd);
    return f;
}

bool read_key(std::FILE* f, const std::string& expected) {
    uint32_t n = 0;
    if (std::fread(&n, sizeof n, 1, f) != 1 || n != expected.size() || n > kMaxKey) return false;
    std::string key(n, '\0');
    return std::fread(key.data(), 1, n, f) == n && key == expected;
}

bool write_key(std::FILE* f, const std::string& key) {
    const uint32_t n = uint32_t(key.size());
    return std::fwrite(&n, sizeof n, 1, f) == 1 && std::fwrite(key.data(), 1, n, f) == n;
}

}  // namespace

std::optional<Image> FileLutCache::load(const std::string& key, std::string* pixels_sha256) {
    File file{open_entry(dir_ / (key + ".lut"))};
    if (!file.f) return std::nullopt;
    char magic[8];
    int32_t wh[2];
    if (std::fread(magic, 1, 8, file.f) != 8 || std::memcmp(magic, kMagic, 8) != 0) return std::nullopt;
    if (std::fread(wh, sizeof(int32_t), 2, file.f) != 2 || wh[0] < 1 || wh[1] < 1 || wh[0] > 65536 || wh[1] > 65536)
        return std::nullopt;
    char digest[65] = {0};
    if (std::fread(digest, 1, 64, file.f) != 64) return std::nullopt;
    if (!read_key(file.f, key)) return std::nullopt;  // another LUT's entry under this name
    Image lut(wh[0], wh[1], Uninitialized{});  // read whole below, or a miss
    if (std::fread(lut.pixels.data(), sizeof(float), lut.pixels.size(), file.f) != lut.pixels.size())
        return std::nullopt;  // truncated: a miss, and store() replaces it
    char extra;
    if (std::fread(&extra, 1, 1, file.f) != 0) return std::nullopt;  // too long: not what we wrote
    if (!all_finite(lut.pixels)) return std::nullopt;
    std::string sha = io::sha256_bytes(lut.pixels.data(), lut.pixels.size() * sizeof(float));
    if (entry_digest(key, sha) != std::string(digest, 64)) return std::nullopt;  // damaged
    if (pixels_sha256) *pixels_sha256 = std::move(sha);
    return lut;
}

void FileLutCache::store(const std::string& key, const Image& lut, std::string* pixels_sha256) {
    const std::string sha = io::sha256_bytes(lut.pixels.data(), lut.pixels.size() * sizeof(float));
    if (pixels_sha256) *pixels_sha256 = sha;  // whether or not the entry can be written
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec || key.size() > kMaxKey) return;  // a cache that cannot be written is not an error
    const fs::path final_path = dir_ / (key + ".lut");
    const fs::path tmp = dir_ / (key + ".tmp-" + tmp_tag() + ".lut");
    bool ok = false;
    {
        File file{std::fopen(tmp.c_str(), "wb")};
        const int32_t wh[2] = {lut.width, lut.height};
        const std::string digest = entry_digest(key, sha);
        ok = file.f && std::fwrite(kMagic, 1, 8, file.f) == 8 && std::fwrite(wh, sizeof(int32_t), 2, file.f) == 2 &&
             std::fwrite(digest.data(), 1, 64, file.f) == 64 && write_key(file.f, key) &&
             std::fwrite(lut.pixels.data(), sizeof(float), lut.pixels.size(), file.f) == lut.pixels.size() &&
             std::fflush(file.f) == 0;
    }
    if (ok) fs::rename(tmp, final_path, ec);
    fs::remove(tmp, ec);
}

std::string encoded_lut_key(const Image& lut, const std::string& encoding) {
    return encoded_lut_key_of(io::sha256_bytes(lut.pixels.data(), lut.pixels.size() * sizeof(float)), encoding);
}

std::string encoded_lut_key_of(const std::string& pixels_sha256, const std::string& encoding) {
    return "brdf_lut-file-" + pixels_sha256 + "-" + encoding;
}

namespace {

// <key>.enc: magic, the checksum of the key and the bytes (as above), the
// key's length (uint32) and the key, the bytes.
constexpr char kEncodedMagic[8] = {'I', 'B', 'L', 'L', 'U', 'T', 'F', '2'};

// The whole file, or nothing (missing, not a regular file, unreadable or
// larger than `limit`).
std::optional<std::string> read_all(const fs::path& p, uintmax_t limit) {
    File file{open_entry(p)};
    if (!file.f) return std::nullopt;
    struct stat st {};
    if (::fstat(::fileno(file.f), &st) != 0 || uintmax_t(st.st_size) > limit) return std::nullopt;
    std::string bytes(size_t(st.st_size), '\0');
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

// The head of key's entry for a payload whose sha256 is `payload_sha256`.
std::string encoded_head(const std::string& key, const std::string& payload_sha256) {
    const uint32_t n = uint32_t(key.size());
    return std::string(kEncodedMagic, 8) + entry_digest(key, payload_sha256) +
           std::string(reinterpret_cast<const char*>(&n), sizeof n) + key;
}

}  // namespace

bool FileLutCache::copy_encoded(const std::string& key, const fs::path& to, std::string* sha256) {
    // The entry streamed to `to` in pieces, its bytes hashed once on the
    // way (the checksum's payload digest, and the copy's sha256): a bake
    // holds 256 KB of it at a time, not the whole file.
    if (key.size() > kMaxKey) return false;
    File in{open_entry(dir_ / (key + ".enc"))};
    if (!in.f) return false;
    struct stat st {};
    const size_t head = 8 + 64 + sizeof(uint32_t) + key.size();
    if (::fstat(::fileno(in.f), &st) != 0 || uintmax_t(st.st_size) < head ||
        uintmax_t(st.st_size) > kMaxEncoded + head)
        return false;
    std::string got(head, '\0');
    if (std::fread(got.data(), 1, head, in.f) != head) return false;
    // The magic and the key it was stored under (the checksum is compared once the bytes are read).
    const uint32_t n = uint32_t(key.size());
    if (got.compare(0, 8, kEncodedMagic, 8) != 0 ||
        got.compare(72, std::string::npos, std::string(reinterpret_cast<const char*>(&n), sizeof n) + key) != 0)
        return false;  // damaged or misnamed
    bool ok = false;
    {
        File out{std::fopen(to.c_str(), "wb")};
        if (out.f) {
            io::Sha256 payload;
            constexpr size_t kChunk = size_t(1) << 18;
            const std::unique_ptr<char[]> buf(new char[kChunk]);
            size_t left = size_t(st.st_size) - head;
            ok = true;
            while (ok && left > 0) {
                const size_t want = std::min(kChunk, left);
                ok = std::fread(buf.get(), 1, want, in.f) == want && std::fwrite(buf.get(), 1, want, out.f) == want;
                if (ok) payload.update(buf.get(), want);
                left -= want;
            }
            char extra;
            ok = ok && std::fread(&extra, 1, 1, in.f) == 0 && std::fflush(out.f) == 0;  // not grown while read
            if (ok) {
                std::string digest = payload.hex();
                ok = got == encoded_head(key, digest);  // the whole head, checksum included
                if (ok && sha256) *sha256 = std::move(digest);
            }
        }
    }
    if (ok) return true;
    std::error_code ec;
    fs::remove(to, ec);  // damaged, or not written: the caller writes it itself
    return false;
}

void FileLutCache::store_encoded(const std::string& key, const fs::path& from) {
    if (key.size() > kMaxKey) return;
    const std::optional<std::string> bytes = read_all(from, kMaxEncoded);
    if (!bytes) return;
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) return;  // a cache that cannot be written is not an error
    const std::string entry = encoded_head(key, io::sha256_bytes(bytes->data(), bytes->size())) + *bytes;
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
