// Opening a path for reading only when it is a regular file.
#pragma once
#include <string>

namespace iblbake::io {

// A read-only descriptor of `path`, or -1 when it cannot be opened or is not
// a regular file. The open never blocks (a FIFO's open would wait for a
// writer; a device never ends); with follow_links false a symbolic link is
// refused too (O_NOFOLLOW). The caller closes the descriptor.
int open_regular_file(const std::string& path, bool follow_links = true);

}  // namespace iblbake::io
