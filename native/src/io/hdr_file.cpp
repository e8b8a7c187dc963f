// Radiance RGBE files (.hdr) read directly, scanline by scanline, as
// OpenImageIO's reader (Bruce Walter's rgbe.c, which Blender's and most
// others' descend from too) reads them, to the bit: the same header rules,
// the same run-length decoding and the same value, mantissa x 2^(exponent -
// 136) (no half step added), EXPOSURE not applied. Reading them here instead
// of through the OpenImageIO plugin keeps an HDR bake free of OpenImageIO's
// few hundred libraries (about 120 MB of a bake's peak memory, and a quarter
// of a second to load) and lets the self-contained wheels, which carry no
// plugin, read the format most HDRI libraries publish.
//
// The format (Greg Ward, "Real Pixels", Graphics Gems II, 1991; Radiance's
// color.c): a text header of lines ending in a blank line ("#?RADIANCE",
// "FORMAT=32-bit_rle_rgbe", others ignored), a resolution line ("-Y H +X W":
// rows top to bottom, each left to right; the other seven orders are read
// whole by the plugin, which turns them), then H scanlines of W pixels of
// four bytes (R, G, B mantissas and a shared exponent). A scanline 8 to
// 32767 wide may be run-length encoded: the bytes 2, 2, W >> 8, W & 255,
// then each of the four components in runs (a count c > 128: the next byte
// c - 128 times; else c bytes as they are); a scanline not starting so is
// W flat pixels.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "raw_pixels.h"

namespace iblbake::io::detail {

namespace {

constexpr size_t kMaxHeader = 64 * 1024;  // Radiance's own headers hold commands, not pictures

struct HdrLayout {
    int width = 0, height = 0;
    long data_offset = 0;  // where the first scanline starts
    bool turned = false;   // a resolution line other than -Y H +X W
};

// A header line without its '\n' and trailing blanks (a '\r' of a file
// passed through Windows); false at the end of the file.
bool header_line(std::FILE* f, std::string& line, size_t& used) {
    line.clear();
    bool ended = false;
    for (int c; (c = std::getc(f)) != EOF;) {
        if (++used > kMaxHeader)
            throw std::runtime_error("the Radiance header is longer than 64 KB (no blank line ends it)");
        if (c == '\n') {
            ended = true;
            break;
        }
        line.push_back(char(c));
    }
    while (!line.empty() && std::strchr(" \t\r", line.back())) line.pop_back();
    return ended || !line.empty();
}

// Reads the header and the resolution line (rgbe.c's rules: a FORMAT line is required).
HdrLayout read_header(std::FILE* f) {
    HdrLayout out;
    std::string line;
    size_t used = 0;
    bool format = false;
    bool first = true;
    for (;;) {
        if (!header_line(f, line, used)) throw std::runtime_error("the file ends inside its Radiance header");
        if (line.empty()) break;
        if (first && line.rfind("#?", 0) == 0) {
            first = false;
            continue;  // the program type: RADIANCE, RGBE, ...
        }
        first = false;
        if (line.rfind("FORMAT=", 0) == 0) {
            const std::string value = line.substr(7);
            if (value != "32-bit_rle_rgbe")
                throw std::runtime_error("a Radiance file in FORMAT=" + value + ", which iblbake does not read "
                                         "(only 32-bit_rle_rgbe)");
            format = true;
        }
    }
    if (!format) throw std::runtime_error("no FORMAT=32-bit_rle_rgbe line in the Radiance header");
    if (!header_line(f, line, used)) throw std::runtime_error("the file ends before its resolution line");
    char a[3] = {0}, b[3] = {0};
    long n1 = 0, n2 = 0;
    char rest = 0;
    if (std::sscanf(line.c_str(), "%2s %ld %2s %ld %c", a, &n1, b, &n2, &rest) != 4 || std::strlen(a) != 2 ||
        std::strlen(b) != 2 || !std::strchr("+-", a[0]) || !std::strchr("+-", b[0]) ||
        !((a[1] == 'Y' && b[1] == 'X') || (a[1] == 'X' && b[1] == 'Y')))
        throw std::runtime_error("no resolution line (such as '-Y 1024 +X 2048') after the Radiance header");
    if (n1 < 1 || n2 < 1 || n1 > (1L << 30) || n2 > (1L << 30))
        throw std::runtime_error("the Radiance resolution line gives no pixels: '" + line + "'");
    out.turned = !(a[0] == '-' && a[1] == 'Y' && b[0] == '+' && b[1] == 'X');
    out.height = int(a[1] == 'Y' ? n1 : n2);
    out.width = int(a[1] == 'Y' ? n2 : n1);
    out.data_offset = std::ftell(f);
    return out;
}

// One scanline's planes (R, G, B mantissas, exponents) as floats, RGB
// interleaved, as rgbe.c makes them: m x 2^(e - 136), and 0 for e = 0 (every
// mantissa of such a pixel reads 0). The scale 2^(e - 136) is exact in a
// float and its bits are made from e (a normal float from e = 10, a
// subnormal below), so that the loop vectorises without a table; built per
// instruction set.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void rgbe_planes_to_float(const unsigned char* r, const unsigned char* g, const unsigned char* b,
                          const unsigned char* e, size_t w, float* out) {
    for (size_t x = 0; x < w; ++x) {
        const uint32_t ex = e[x];
        const uint32_t bits = ex >= 10u ? (ex - 9u) << 23 : ex == 0u ? 0u : 1u << (ex + 13u);
        float f;
        std::memcpy(&f, &bits, sizeof(f));
        out[3 * x] = float(r[x]) * f;
        out[3 * x + 1] = float(g[x]) * f;
        out[3 * x + 2] = float(b[x]) * f;
    }
}

// The scanlines of an -Y H +X W file, in order, as RGBE bytes (four per pixel).
class HdrRows final : public SequentialRows {
public:
    HdrRows(const std::string& path, uintmax_t file_size) : file_(std::fopen(path.c_str(), "rb"), &std::fclose) {
        if (!file_) throw std::runtime_error(std::strerror(errno));
        layout_ = read_header(file_.get());
        header.format = "hdr";
        header.width = layout_.width;
        header.height = layout_.height;
        header.channels = 3;
        header.is_float = true;
        header.colorspace = "linear";
        if (!layout_.turned) check_declared(layout_.width, layout_.height, 3, file_size);
    }
    bool turned() const { return layout_.turned; }

private:
    void restart() override {
        if (std::fseek(file_.get(), layout_.data_offset, SEEK_SET) != 0) throw std::runtime_error(std::strerror(errno));
        at_ = have_ = 0;
        next_ = 0;
    }
    // Each scanline's bytes are kept as four planes (R, G, B and exponent,
    // W bytes each): run-length decoding writes them so, and to_float reads
    // them without an interleaving pass.
    void take(int n) override {
        const size_t w = size_t(layout_.width);
        bytes_.resize(size_t(n) * w * 4);
        for (int k = 0; k < n; ++k) scanline(bytes_.data() + size_t(k) * w * 4);
        next_ += n;
    }
    void to_float(int n, float* out) const override {
        const size_t w = size_t(layout_.width);
        for (int k = 0; k < n; ++k) {
            const unsigned char* r = bytes_.data() + size_t(k) * w * 4;
            rgbe_planes_to_float(r, r + w, r + 2 * w, r + 3 * w, w, out + size_t(k) * w * 3);
        }
    }

    [[noreturn]] void ends() const {
        throw std::runtime_error("the file ends in scanline " + std::to_string(next_ + 1) + " of " +
                                 std::to_string(layout_.height) + ": truncated");
    }
    [[noreturn]] void run_past_end() const {
        throw std::runtime_error("scanline " + std::to_string(next_ + 1) + " has a run past its end: damaged");
    }
    // The file's bytes through a buffer of its own (a run is two bytes: a
    // call of fread each would cost more than the decoding).
    void read_exactly(unsigned char* to, size_t n) {
        while (n > 0) {
            if (at_ == have_) {
                at_ = 0;
                have_ = std::fread(buffer_.data(), 1, buffer_.size(), file_.get());
                if (have_ == 0) ends();
            }
            const size_t k = std::min(n, have_ - at_);
            std::memcpy(to, buffer_.data() + at_, k);
            at_ += k;
            to += k;
            n -= k;
        }
    }
    // A flat scanline (W pixels of four bytes, `first` its first pixel when
    // already read) into the planes.
    void flat(unsigned char* planes, const unsigned char* first) {
        const size_t w = size_t(layout_.width);
        planar_.resize(w * 4);
        if (first) {
            std::memcpy(planar_.data(), first, 4);
            read_exactly(planar_.data() + 4, (w - 1) * 4);
        } else {
            read_exactly(planar_.data(), w * 4);
        }
        for (size_t x = 0; x < w; ++x)
            for (size_t c = 0; c < 4; ++c) planes[c * w + x] = planar_[4 * x + c];
    }
    // One scanline into `planes` (4 planes of width bytes).
    void scanline(unsigned char* planes) {
        const int w = layout_.width;
        if (w < 8 || w > 0x7fff) return flat(planes, nullptr);  // never run-length encoded
        unsigned char head[4];
        read_exactly(head, 4);
        if (head[0] != 2 || head[1] != 2 || (head[2] & 0x80) != 0) return flat(planes, head);
        if (((int(head[2]) << 8) | head[3]) != w)
            throw std::runtime_error("scanline " + std::to_string(next_ + 1) + " says it is " +
                                     std::to_string((int(head[2]) << 8) | head[3]) + " pixels wide, not " +
                                     std::to_string(w) + ": damaged");
        for (int c = 0; c < 4; ++c) {
            unsigned char* at = planes + size_t(c) * w;
            unsigned char* const end = at + w;
            while (at < end) {
                // A run is a count and one byte (c > 128: that byte c - 128
                // times) or c bytes. With a whole run buffered (at most 1 +
                // 128 bytes) it is taken straight from the buffer, else
                // through read_exactly.
                const bool buffered = have_ - at_ >= 129;
                unsigned char head[2];
                if (!buffered) read_exactly(head, 2);
                const unsigned char* p = buffered ? buffer_.data() + at_ : head;
                const bool repeat = p[0] > 128;
                const int count = repeat ? p[0] - 128 : p[0];
                if (count == 0 || count > end - at) run_past_end();
                if (repeat) {
                    std::memset(at, p[1], size_t(count));
                    if (buffered) at_ += 2;
                } else if (buffered) {
                    std::memcpy(at, p + 1, size_t(count));
                    at_ += 1 + size_t(count);
                } else {
                    at[0] = p[1];
                    if (count > 1) read_exactly(at + 1, size_t(count - 1));
                }
                at += count;
            }
        }
    }

    std::unique_ptr<std::FILE, int (*)(std::FILE*)> file_;
    HdrLayout layout_;
    std::vector<unsigned char> bytes_, planar_;
    std::vector<unsigned char> buffer_ = std::vector<unsigned char>(size_t(1) << 18);
    size_t at_ = 0, have_ = 0;  // the buffer's next byte and its end
};

}  // namespace

std::unique_ptr<RawRows> hdr_rows(const std::string& path, uintmax_t file_size) {
    auto rows = std::make_unique<HdrRows>(path, file_size);
    if (rows->turned()) return nullptr;
    return rows;
}

}  // namespace iblbake::io::detail
