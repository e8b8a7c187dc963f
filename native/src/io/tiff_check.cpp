// A TIFF cut short still opens, and libtiff reads its missing strips as
// black with a mere warning: before OpenImageIO reads one, the first
// image's strip (or tile) table is checked against the file's size.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "raw_pixels.h"

namespace iblbake::io::detail {

namespace {
class Reader {
public:
    Reader(std::FILE* f, bool big_endian) : f_(f), be_(big_endian) {}
    uint64_t uint(uint64_t offset, int bytes) {
        unsigned char b[8] = {0};
        if (std::fseek(f_, long(offset), SEEK_SET) != 0 || std::fread(b, 1, size_t(bytes), f_) != size_t(bytes))
            throw std::runtime_error("TIFF file is truncated (its directory lies past the end)");
        uint64_t v = 0;
        for (int i = 0; i < bytes; ++i) v |= uint64_t(b[be_ ? bytes - 1 - i : i]) << (8 * i);
        return v;
    }

private:
    std::FILE* f_;
    bool be_;
};

int type_size(uint64_t type) {
    switch (type) {
        case 3: return 2;   // SHORT
        case 4: return 4;   // LONG
        case 13: return 4;  // IFD
        case 16: return 8;  // LONG8
        default: return 0;
    }
}
}  // namespace

void check_tiff_complete(const std::string& path, uintmax_t file_size) {
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
    if (!f) return;  // the reader says why
    unsigned char head[4];
    if (std::fread(head, 1, 4, f.get()) != 4) return;
    const bool be = head[0] == 'M';
    Reader r(f.get(), be);
    const uint64_t magic = r.uint(2, 2);
    if (magic != 42 && magic != 43) return;
    const bool big = magic == 43;
    const int off_bytes = big ? 8 : 4, count_bytes = big ? 8 : 2, entry_bytes = big ? 20 : 12;
    const uint64_t ifd = r.uint(big ? 8 : 4, off_bytes);
    const uint64_t entries = r.uint(ifd, count_bytes);
    if (entries > 4096) throw std::runtime_error("TIFF directory is damaged (" + std::to_string(entries) + " entries)");
    // Offsets and byte counts of the strips (273, 279) or tiles (324, 325).
    std::vector<uint64_t> offsets, counts;
    for (uint64_t e = 0; e < entries; ++e) {
        const uint64_t at = ifd + count_bytes + e * entry_bytes;
        const uint64_t tag = r.uint(at, 2), type = r.uint(at + 2, 2), n = r.uint(at + 4, big ? 8 : 4);
        if (tag != 273 && tag != 279 && tag != 324 && tag != 325) continue;
        const int size = type_size(type);
        if (size == 0 || n == 0 || n > (uint64_t(1) << 24))
            throw std::runtime_error("TIFF strip table is damaged");
        const uint64_t value_at = at + 4 + (big ? 8 : 4);
        const uint64_t data = n * size <= uint64_t(off_bytes) ? value_at : r.uint(value_at, off_bytes);
        if (data + n * size > file_size) throw std::runtime_error("TIFF file is truncated (its strip table is cut)");
        std::vector<uint64_t>& into = (tag == 273 || tag == 324) ? offsets : counts;
        into.resize(size_t(n));
        for (uint64_t i = 0; i < n; ++i) into[size_t(i)] = r.uint(data + i * size, size);
    }
    if (offsets.empty() || offsets.size() != counts.size()) return;  // libtiff decides
    for (size_t i = 0; i < offsets.size(); ++i)
        if (offsets[i] + counts[i] > file_size)
            throw std::runtime_error("TIFF file is truncated (strip " + std::to_string(i) + " of " +
                                     std::to_string(offsets.size()) + " lies past the end)");
}

}  // namespace iblbake::io::detail
