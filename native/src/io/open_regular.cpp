#include "iblbake/io/open_regular.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

namespace iblbake::io {

int open_regular_file(const std::string& path, bool follow_links) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | (follow_links ? 0 : O_NOFOLLOW));
    if (fd < 0) return -1;
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        ::close(fd);
        return -1;
    }
    return fd;
}

std::optional<std::string> read_regular_file(const std::string& path, size_t limit, bool follow_links) {
    const int fd = open_regular_file(path, follow_links);
    if (fd < 0) return std::nullopt;
    std::string text;
    char buf[65536];
    ssize_t n;
    while ((n = ::read(fd, buf, sizeof buf)) > 0 && text.size() <= limit) text.append(buf, size_t(n));
    ::close(fd);
    if (n < 0 || text.size() > limit) return std::nullopt;
    return text;
}

}  // namespace iblbake::io
