// Atomic output folders: a bake is written into a staging folder beside the
// destination and swapped in only when complete, so a failed or cancelled
// bake never leaves a half-written folder and an earlier good bake survives.
#pragma once
#include <filesystem>
#include <string>

namespace iblbake::io {

class StagingDir {
public:
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
