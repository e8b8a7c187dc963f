#include "iblbake/io/output_dir.h"

#include <fcntl.h>
#include <stdio.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <random>
#include <stdexcept>

namespace iblbake::io {

namespace fs = std::filesystem;

namespace {
std::string random_suffix() {
    std::random_device rd;
    const char* digits = "0123456789abcdef";
    std::string s;
    for (int i = 0; i < 8; ++i) s += digits[rd() % 16];
    return s;
}

bool exchange(const fs::path& a, const fs::path& b) {
#ifdef SYS_renameat2
    constexpr unsigned kRenameExchange = 2;  // RENAME_EXCHANGE
    return syscall(SYS_renameat2, AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), kRenameExchange) == 0;
#else
    (void)a; (void)b;
    return false;
#endif
}
}  // namespace

StagingDir::StagingDir(const fs::path& destination) : destination_(fs::absolute(destination)) {
    fs::path parent = destination_.parent_path();
    if (destination_.filename().empty()) {  // "out/" -> "out"
        destination_ = parent;
        parent = destination_.parent_path();
    }
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw std::runtime_error("cannot create '" + parent.string() + "': " + ec.message());
    if (fs::exists(destination_) && !fs::is_directory(destination_))
        throw std::runtime_error("output '" + destination_.string() + "' exists and is not a folder");
    staging_ = parent / ("." + destination_.filename().string() + ".iblbake-" + random_suffix());
    if (!fs::create_directory(staging_, ec) || ec)
        throw std::runtime_error("cannot create '" + staging_.string() + "': " + ec.message());
}

StagingDir::~StagingDir() {
    if (!committed_) {
        std::error_code ec;
        fs::remove_all(staging_, ec);
    }
}

void StagingDir::commit() {
    std::error_code ec;
    if (fs::exists(destination_)) {
        if (exchange(staging_, destination_)) {
            fs::remove_all(staging_, ec);  // staging_ now names the old bake
        } else {
            const fs::path old = destination_.parent_path() /
                                 ("." + destination_.filename().string() + ".old-" + random_suffix());
            fs::rename(destination_, old);
            fs::rename(staging_, destination_);
            fs::remove_all(old, ec);
        }
    } else {
        fs::rename(staging_, destination_);
    }
    committed_ = true;
}

}  // namespace iblbake::io
