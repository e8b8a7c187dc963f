#include "iblbake/io/open_regular.h"

#include <fcntl.h>
#include <sys/stat.h>
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

}  // namespace iblbake::io
