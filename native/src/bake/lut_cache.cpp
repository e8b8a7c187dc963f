#include "iblbake/bake/lut_cache.h"

#include <unistd.h>

#include <cstdlib>

#include "iblbake/io/image_io.h"

namespace iblbake {

namespace fs = std::filesystem;

std::string lut_cache_key(int size, LutModel model, const LutQuality& q) {
    return "brdf_lut-v" + std::to_string(kLutAlgorithmVersion) + "-" + lut_model_name(model) + "-" +
           std::to_string(size) + "-p" + std::to_string(q.phi_points) + "-u" + std::to_string(q.u_points) +
           (q.row_nodes >= 4 && q.row_nodes < size ? "-k" + std::to_string(q.row_nodes) : "");
}

std::optional<Image> FileLutCache::load(const std::string& key) {
    const fs::path p = dir_ / (key + ".exr");
    std::error_code ec;
    if (!fs::is_regular_file(p, ec)) return std::nullopt;
    try {
        io::LoadedImage li = io::read_image(p.string());
        return std::move(li.image);
    } catch (const std::exception&) {
        return std::nullopt;  // a damaged entry is a miss; store() replaces it
    }
}

void FileLutCache::store(const std::string& key, const Image& lut) {
    std::error_code ec;
    fs::create_directories(dir_, ec);
    if (ec) return;  // a cache that cannot be written is not an error
    const fs::path final_path = dir_ / (key + ".exr");
    const fs::path tmp = dir_ / (key + ".tmp-" + std::to_string(::getpid()) + ".exr");
    try {
        io::write_exr(tmp.string(), lut, io::ExrPixel::Float);
        fs::rename(tmp, final_path, ec);
    } catch (const std::exception&) {
    }
    fs::remove(tmp, ec);
}

fs::path FileLutCache::default_dir() {
    if (const char* d = std::getenv("IBLBAKE_CACHE_DIR"); d && *d) return d;
    if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return fs::path(x) / "iblbake";
    if (const char* h = std::getenv("HOME"); h && *h) return fs::path(h) / ".cache" / "iblbake";
    return fs::temp_directory_path() / "iblbake-cache";
}

}  // namespace iblbake
