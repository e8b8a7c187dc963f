#include "iblbake/io/output_dir.h"

#include <fcntl.h>
#include <stdio.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <system_error>

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

namespace {
fs::path normalised(const fs::path& p) {
    if (p.empty()) throw std::runtime_error("the output folder must be a non-empty path");
    fs::path a = fs::weakly_canonical(fs::absolute(p));
    if (a.filename().empty()) a = a.parent_path();  // "out/" -> "out"
    return a;
}

bool is_within(const fs::path& inner, const fs::path& outer) {  // inner == outer or below it
    auto i = inner.begin(), o = outer.begin();
    for (; o != outer.end(); ++o, ++i)
        if (i == inner.end() || *i != *o) return false;
    return true;
}

bool holds_a_bake(const fs::path& dir) {
    std::ifstream f(dir / "manifest.json");
    if (!f) return false;
    const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    return text.find("\"generator\": \"iblbake\"") != std::string::npos;
}

const char* kStagingTag = ".iblbake-";
}  // namespace

void check_replaceable(const fs::path& destination, const fs::path& keep) {
    const fs::path dest = normalised(destination);
    std::error_code ec;
    if (dest == dest.root_path()) throw std::runtime_error("refusing to write a bake over '/'");
    if (is_within(fs::current_path(ec), dest))
        throw std::runtime_error("output folder '" + dest.string() + "' is the current folder or holds it");
    if (!keep.empty() && is_within(fs::weakly_canonical(fs::absolute(keep)), dest))
        throw std::runtime_error("output folder '" + dest.string() + "' holds the source image '" + keep.string() +
                                 "'; choose another folder");
    if (!fs::exists(dest, ec)) return;
    if (!fs::is_directory(dest, ec))
        throw std::runtime_error("output '" + dest.string() + "' exists and is not a folder");
    if (fs::is_empty(dest, ec) || holds_a_bake(dest)) return;
    throw std::runtime_error("output folder '" + dest.string() +
                             "' exists and holds something other than an iblbake bake (no iblbake "
                             "manifest.json); refusing to replace it");
}

StagingDir::StagingDir(const fs::path& destination) : destination_(normalised(destination)) {
    check_replaceable(destination_);
    const fs::path parent = destination_.parent_path();
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw std::runtime_error("cannot create '" + parent.string() + "': " + ec.message());
    // Staging folders of bakes that were killed: named .NAME.iblbake-PID-XXXX,
    // removed when that process no longer exists.
    const std::string prefix = "." + destination_.filename().string() + kStagingTag;
    for (const auto& e : fs::directory_iterator(parent, ec)) {
        const std::string name = e.path().filename().string();
        if (name.rfind(prefix, 0) != 0) continue;
        const std::string rest = name.substr(prefix.size());
        const long pid = std::strtol(rest.c_str(), nullptr, 10);
        if (pid > 0 && !fs::exists("/proc/" + std::to_string(pid), ec)) fs::remove_all(e.path(), ec);
    }
    staging_ = parent / (prefix + std::to_string(::getpid()) + "-" + random_suffix());
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
            fs::rename(staging_, destination_, ec);
            if (ec) {  // put the earlier bake back
                std::error_code ec2;
                fs::rename(old, destination_, ec2);
                throw std::runtime_error("cannot move the bake into '" + destination_.string() + "': " + ec.message());
            }
            fs::remove_all(old, ec);
        }
    } else {
        fs::rename(staging_, destination_);
    }
    committed_ = true;
}

}  // namespace iblbake::io
