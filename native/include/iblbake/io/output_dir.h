// Atomic output folders: a bake is written into a staging folder beside the
// destination and swapped in only when complete, so a failed or cancelled
// bake never leaves a half-written folder and an earlier good bake survives.
#pragma once
#include <exception>
#include <filesystem>
#include <string>

namespace iblbake::io {

// Throws std::runtime_error unless `destination` may be replaced by a bake:
// it does not exist, is an empty folder, or holds an earlier bake (a
// manifest.json written by iblbake); and it is neither the current folder
// (or one above it) nor a folder that holds `keep` (the source image).
void check_replaceable(const std::filesystem::path& destination, const std::filesystem::path& keep = {});

// `text` with every staging folder's name (".NAME.iblbake-PID-XXXXXXXX")
// replaced by the output folder it stands for (NAME): messages name the
// user's path, not the hidden one the bake wrote into.
std::string outside_staging(const std::string& text);
// Rethrows `error`; a std::runtime_error's message through outside_staging().
[[noreturn]] void rethrow_outside_staging(const std::exception_ptr& error);

class StagingDir {
public:
    // Checks the destination (check_replaceable), removes staging folders
    // that killed bakes left beside it (their process is gone), and makes a
    // new one named after this process.
    explicit StagingDir(const std::filesystem::path& destination);
    ~StagingDir();  // removes the staging folder unless committed
    StagingDir(const StagingDir&) = delete;
    StagingDir& operator=(const StagingDir&) = delete;

    const std::filesystem::path& path() const { return staging_; }
    // Replace the destination by the staging folder (renameat2 RENAME_EXCHANGE
    // where the destination exists, so there is no moment without one), then
    // remove the old folder, checked again first: files added to it during
    // the bake (or a folder made there) are swapped back and kept, and this
    // throws.
    void commit();

private:
    std::filesystem::path destination_, staging_;
    bool committed_ = false;
    int lock_ = -1;  // flock held on the staging folder: it is not stale
};

}  // namespace iblbake::io
