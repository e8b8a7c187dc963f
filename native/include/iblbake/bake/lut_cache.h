// A cache of tables that depend on settings alone, made once and reused by
// every later bake (across scenes and processes): BRDF LUTs.
#pragma once
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "iblbake/ibl/brdf_lut.h"
#include "iblbake/image/image.h"

namespace iblbake {

// Bumped whenever the LUT quadrature changes, so stale entries are never read.
constexpr int kLutAlgorithmVersion = 2;

// The cache key: every setting that changes a texel.
std::string lut_cache_key(int size, LutModel model, const LutQuality& q);

class LutCache {
public:
    virtual ~LutCache() = default;
    // `pixels_sha256`, when given, receives the sha256 of the table's pixels
    // (their bytes as floats) when the cache knows it (load: the table found;
    // store: the table stored), else is left empty.
    virtual std::optional<Image> load(const std::string& key, std::string* pixels_sha256 = nullptr) = 0;
    virtual void store(const std::string& key, const Image& lut, std::string* pixels_sha256 = nullptr) = 0;
    // A LUT's file as a writer encoded it (encoded_lut_key()): copied to `to`
    // when cached (false: not cached, `to` untouched), stored from `from`.
    // Copying the bytes is cheaper than encoding the table again (a zip
    // float EXR of 512 x 512 costs about 50 ms of CPU). `sha256`, when given,
    // receives the copied file's sha256 (the cache verified it). Default: no such cache.
    virtual bool copy_encoded(const std::string& /*key*/, const std::filesystem::path& /*to*/,
                              std::string* /*sha256*/ = nullptr) {
        return false;
    }
    virtual void store_encoded(const std::string& /*key*/, const std::filesystem::path& /*from*/) {}
};

// The key of a LUT's encoded file: its pixels' sha256 and `encoding` (which
// names the container, the pixel type and the writer's version), so a file
// is only ever reused for the very same table written the same way.
std::string encoded_lut_key(const Image& lut, const std::string& encoding);
// The same from the pixels' sha256 when it is known (LutCache::load, store).
std::string encoded_lut_key_of(const std::string& pixels_sha256, const std::string& encoding);

// Raw float files (<key>.lut) in a folder, read back in one call; writes are
// atomic (temporary file, then rename); unreadable, truncated or foreign
// entries count as misses.
class FileLutCache : public LutCache {
public:
    explicit FileLutCache(std::filesystem::path dir) : dir_(std::move(dir)) {}
    std::optional<Image> load(const std::string& key, std::string* pixels_sha256 = nullptr) override;
    void store(const std::string& key, const Image& lut, std::string* pixels_sha256 = nullptr) override;
    // <key>.enc: a magic, the sha256 of the bytes, the bytes; a damaged
    // entry is a miss (and is replaced by the next store_encoded()).
    bool copy_encoded(const std::string& key, const std::filesystem::path& to, std::string* sha256 = nullptr) override;
    void store_encoded(const std::string& key, const std::filesystem::path& from) override;
    const std::filesystem::path& dir() const { return dir_; }
    // $IBLBAKE_CACHE_DIR, else $XDG_CACHE_HOME/iblbake, else ~/.cache/iblbake.
    static std::filesystem::path default_dir();

private:
    std::filesystem::path dir_;
};

}  // namespace iblbake
