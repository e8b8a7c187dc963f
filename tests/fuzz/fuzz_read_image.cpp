// libFuzzer target for the image readers (io::read_image: EXR through
// OpenEXR, PNG through libpng, the TIFF strip check, everything else through
// the OpenImageIO plugin) and their row readers (io::open_rows, the
// streaming bake's). Built and run by scripts/fuzz.sh with clang's
// -fsanitize=fuzzer,address,undefined. Besides crashes, leaks and undefined
// behaviour it flags: an exception that is not std::exception, an error that
// is not one printable line, an image larger than the documented maximum,
// and rows that differ from read_image's image (or rows read to the end of a
// file read_image refuses).
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "iblbake/io/image_io.h"
#include "iblbake/io/row_reader.h"

namespace {
// The file's extension decides the reader only when the magic bytes name
// none (Targa, unknown): the first input byte picks one.
const char* kExtensions[] = {".exr", ".png", ".hdr", ".tga", ".tif", ".jpg", ".bmp", ".pfm"};

const std::string& scratch_base() {
    static const std::string base = [] {
        const char* dir = std::getenv("IBLBAKE_FUZZ_TMP");
        return std::string(dir ? dir : "/dev/shm") + "/iblbake-fuzz-" + std::to_string(::getpid());
    }();
    return base;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size < 1) return 0;
    const std::string path = scratch_base() + kExtensions[data[0] % 8];
    {
        std::FILE* f = std::fopen(path.c_str(), "wb");
        if (!f) std::abort();
        if (size > 1) std::fwrite(data + 1, 1, size - 1, f);
        std::fclose(f);
    }
    auto check_message = [](const std::exception& e) {
        const std::string msg = e.what();
        for (const char c : msg)
            if (c == '\n' || (static_cast<unsigned char>(c) < 0x20)) std::abort();  // not one printable line
    };
    bool whole_ok = false;
    iblbake::Image whole;
    try {
        iblbake::io::LoadedImage img = iblbake::io::read_image(path);
        const auto& im = img.image;
        if (im.width < 1 || im.height < 1 || int64_t(im.width) * im.height > iblbake::io::kMaxSourcePixels ||
            im.pixels.size() != size_t(im.width) * im.height * 3)
            std::abort();  // the reader let through what it promises to refuse
        whole = std::move(img.image);
        whole_ok = true;
    } catch (const std::exception& e) {
        check_message(e);
    }
    // The same file's rows, in bands of 7: read_image's image to the bit, or an error where it has one.
    // Not compared to the bit for EXR: a fuzzed chunk that OpenEXR 3.1 decodes without an error can
    // leave values that depend on what was decoded before it (found here: a two-chunk ZIP file whose
    // row 5 read 0.9 as rows and 2.5e-41 whole, after some 1500 other inputs, and alike alone).
    const bool exr = data[0] % 8 == 0 || (size > 5 && std::memcmp(data + 1, "\x76\x2f\x31\x01", 4) == 0);
    if (exr) whole_ok = false;
    try {
        std::unique_ptr<iblbake::io::RowReader> rows = iblbake::io::open_rows(path);
        if (rows) {
            const int w = rows->width(), h = rows->height();
            if (w < 1 || h < 1 || int64_t(w) * h > iblbake::io::kMaxSourcePixels) std::abort();
            if (whole_ok && (w != whole.width || h != whole.height)) std::abort();
            std::vector<float> band(size_t(w) * 7 * 3);
            for (int y = 0; y < h; y += 7) {
                const int n = std::min(7, h - y);
                rows->read(y, n, band.data());
                if (whole_ok && std::memcmp(band.data(), whole.at(0, y), size_t(w) * n * 3 * sizeof(float)) != 0) {
                    for (size_t k = 0; k < size_t(w) * n * 3; ++k)
                        if (std::memcmp(&band[k], whole.at(0, y) + k, sizeof(float)) != 0) {
                            std::fprintf(stderr, "row %d, texel %d, channel %d: rows %g, read_image %g\n",
                                         y + int(k / 3 / w), int(k / 3 % w), int(k % 3), band[k], whole.at(0, y)[k]);
                            break;
                        }
                    std::abort();  // rows that are not read_image's
                }
            }
            if (!whole_ok && !exr) std::abort();  // every row read of a file read_image refuses
        }
    } catch (const std::exception& e) {
        check_message(e);
        if (whole_ok) std::abort();  // the rows failed where the whole read did not (not EXR: see above)
    }
    std::remove(path.c_str());
    return 0;
}
