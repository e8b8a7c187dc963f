// Atomic output folders: a bake is written into a staging folder beside the
// destination and swapped in only when complete, so a failed or cancelled
// bake never leaves a half-written folder and an earlier good bake survives.
#pragma once
#include <filesystem>
#include <string>

namespace iblbake::io {

// Throws std::runtime_error unless `destination` may be replaced by a bake:
// it does not exist, is an empty folder, or holds an earlier bake (a
// manifest.json written by iblbake); and it is neither the current folder
// (or one above it) nor a folder that holds `keep` (the source image).
void check_replaceable(const std::filesystem::path& destination, const std::filesystem::path& keep = {});

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
    // remove the old folder.
    void commit();

private:
    std::filesystem::path destination_, staging_;
    bool committed_ = false;
};

}  // namespace iblbake::io
