// Opening a path for reading only when it is a regular file.
#pragma once
#include <cstddef>
#include <optional>
#include <string>

namespace iblbake::io {

// A read-only descriptor of `path`, or -1 when it cannot be opened or is not
// a regular file. The open never blocks (a FIFO's open would wait for a
// writer; a device never ends); with follow_links false a symbolic link is
// refused too (O_NOFOLLOW). The caller closes the descriptor.
int open_regular_file(const std::string& path, bool follow_links = true);

// The most a bake's manifest.json is read to (a few KB to a few MB written).
constexpr size_t kMaxManifestBytes = size_t(64) << 20;

// The whole of a regular file (open_regular_file), or nothing: missing, not
// a regular file, unreadable, or longer than `limit` bytes.
std::optional<std::string> read_regular_file(const std::string& path, size_t limit, bool follow_links = true);

}  // namespace iblbake::io
