// A source image decoded a band of rows at a time (issue 28's streaming
// bake, docs/design-streaming.md): the rows read_image() would return, without
// ever holding the whole image.
#pragma once
#include <memory>
#include <string>
#include <vector>

namespace iblbake::io {

// An OpenEXR file (scanline or tiled, single- or multi-part, RGB, a layer's
// RGB, Y or some of R, G, B, luminance-chroma) as rows of linear RGB floats:
// row y of read(y, 1, out) equals row y of read_image(path).image, value for
// value, with the same width, height and warnings (the display window
// padded or dropped as read_image does, grey from one channel). Rows may be
// read in any order and more than once; each call decodes the file's blocks
// that hold them (OpenEXR's thread pool decodes them in parallel).
class ExrRowReader {
public:
    // Throws std::runtime_error ("cannot read '<path>': ...") as read_image
    // does for a file it cannot read, before any pixel is decoded.
    explicit ExrRowReader(const std::string& path);
    ~ExrRowReader();
    ExrRowReader(const ExrRowReader&) = delete;
    ExrRowReader& operator=(const ExrRowReader&) = delete;

    int width() const;
    int height() const;
    const std::vector<std::string>& warnings() const;
    // Rows per call that decode each compressed block once, with a block per
    // thread of OpenEXR's pool (a multiple of the tile height for tiled files).
    int preferred_band() const;
    // Rows y0 .. y0 + rows - 1 (within 0..height-1) into out: rows x width x 3
    // floats, row-major, RGB interleaved.
    void read(int y0, int rows, float* out);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace iblbake::io
