// A source image decoded a band of rows at a time (issue 28's streaming
// bake, docs/design-streaming.md): the rows read_image() would return, without
// ever holding the whole image.
#pragma once
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace iblbake::io {

// A source image as rows of linear RGB floats: row y of read(y, 1, out)
// equals row y of read_image(path).image, value for value, with the same
// width, height, warnings and linearised flag. Calls come one at a time.
class RowReader {
public:
    virtual ~RowReader() = default;
    virtual int width() const = 0;
    virtual int height() const = 0;
    virtual const std::vector<std::string>& warnings() const = 0;
    // Values decoded from sRGB (read_image's LoadedImage::linearised).
    virtual bool linearised() const { return false; }
    // Rows per call that suit the decoder.
    virtual int preferred_band() const = 0;
    // Rows y0 .. y0 + rows - 1 (within 0..height-1) into out: rows x width x 3
    // floats, row-major, RGB interleaved.
    virtual void read(int y0, int rows, float* out) = 0;
    // Whether read_halves() can be called: the rows are IEEE binary16 RGB
    // in the file, every one of them data (no window to pad), so a caller
    // may convert them itself, row by row, where the floats are used.
    virtual bool has_halves() const { return false; }
    // Rows y0 .. y0 + rows - 1 as rows x width x 3 halves, RGB interleaved:
    // the bits whose halves_to_floats() read() returns.
    virtual void read_halves(int /*y0*/, int /*rows*/, uint16_t* /*out*/) {
        throw std::logic_error("RowReader::read_halves: the rows are not halves");
    }
};

// The file as rows, decoded a band at a time: OpenEXR (ExrRowReader), PNG
// (libpng), JPEG (libjpeg), Radiance HDR and PNM/PFM (OpenImageIO's
// scanline reads, in the plugin). Null when it is read whole only: an
// interlaced PNG, a Radiance file stored turned, TIFF and the plugin's other
// formats, or a build without the plugin. Throws
// read_image's error ("cannot read '<path>': ...") for a file it cannot
// read, before any pixel is decoded.
std::unique_ptr<RowReader> open_rows(const std::string& path);

// An OpenEXR file (scanline or tiled, single- or multi-part, RGB, a layer's
// RGB, Y or some of R, G, B, luminance-chroma) as rows of linear RGB floats:
// row y of read(y, 1, out) equals row y of read_image(path).image, value for
// value, with the same width, height and warnings (the display window
// padded or dropped as read_image does, grey from one channel). Rows may be
// read in any order and more than once; each call decodes the file's blocks
// that hold them, in parallel on OpenEXR's thread pool: by OpenEXR, or, for
// scanline ZIP and ZIPS blocks of three HALF channels, by the reader itself
// from the blocks' bytes (src/io/exr_zip.h: the same halves, faster).
class ExrRowReader final : public RowReader {
public:
    // Throws std::runtime_error ("cannot read '<path>': ...") as read_image
    // does for a file it cannot read, before any pixel is decoded.
    explicit ExrRowReader(const std::string& path);
    ~ExrRowReader();
    ExrRowReader(const ExrRowReader&) = delete;
    ExrRowReader& operator=(const ExrRowReader&) = delete;

    int width() const override;
    int height() const override;
    const std::vector<std::string>& warnings() const override;
    // Rows per call that decode each compressed block once, with a block per
    // thread of OpenEXR's pool (a multiple of the tile height for tiled files).
    int preferred_band() const override;
    // Rows y0 .. y0 + rows - 1 (within 0..height-1) into out: rows x width x 3
    // floats, row-major, RGB interleaved.
    void read(int y0, int rows, float* out) override;
    // Three HALF channels, read as RGB (no luminance-chroma) and a data
    // window that is the whole image.
    bool has_halves() const override;
    void read_halves(int y0, int rows, uint16_t* out) override;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace iblbake::io
