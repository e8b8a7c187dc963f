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
    virtual std::optional<Image> load(const std::string& key) = 0;
    virtual void store(const std::string& key, const Image& lut) = 0;
};

// Raw float files (<key>.lut) in a folder, read back in one call; writes are
// atomic (temporary file, then rename); unreadable, truncated or foreign
// entries count as misses.
class FileLutCache : public LutCache {
public:
    explicit FileLutCache(std::filesystem::path dir) : dir_(std::move(dir)) {}
    std::optional<Image> load(const std::string& key) override;
    void store(const std::string& key, const Image& lut) override;
    const std::filesystem::path& dir() const { return dir_; }
    // $IBLBAKE_CACHE_DIR, else $XDG_CACHE_HOME/iblbake, else ~/.cache/iblbake.
    static std::filesystem::path default_dir();

private:
    std::filesystem::path dir_;
};

}  // namespace iblbake
