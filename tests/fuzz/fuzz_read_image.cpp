// libFuzzer target for the image readers (io::read_image: EXR through
// OpenEXR, PNG through libpng, the TIFF strip check, everything else through
// the OpenImageIO plugin). Built and run by scripts/fuzz.sh with clang's
// -fsanitize=fuzzer,address,undefined. Besides crashes, leaks and undefined
// behaviour it flags: an exception that is not std::exception, an error that
// is not one printable line, and an image larger than the documented maximum.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "iblbake/io/image_io.h"

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
    try {
        const iblbake::io::LoadedImage img = iblbake::io::read_image(path);
        const auto& im = img.image;
        if (im.width < 1 || im.height < 1 || int64_t(im.width) * im.height > iblbake::io::kMaxSourcePixels ||
            im.pixels.size() != size_t(im.width) * im.height * 3)
            std::abort();  // the reader let through what it promises to refuse
    } catch (const std::exception& e) {
        const std::string msg = e.what();
        for (const char c : msg)
            if (c == '\n' || (static_cast<unsigned char>(c) < 0x20)) std::abort();  // not one printable line
    }
    std::remove(path.c_str());
    return 0;
}
