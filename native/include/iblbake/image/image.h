// Image types: a lat-long or 2-D RGB float image and a cube of six faces.
// Plain storage, no I/O (that lives in io/).
#pragma once
#include <cstddef>
#include <vector>

namespace iblbake {

// RGB float image, rows top to bottom, pixels interleaved.
struct Image {
    int width = 0, height = 0;
    std::vector<float> pixels;  // width * height * 3

    Image() = default;
    Image(int w, int h) : width(w), height(h), pixels(size_t(w) * size_t(h) * 3, 0.0f) {}
    float* at(int x, int y) { return pixels.data() + (size_t(y) * width + x) * 3; }
    const float* at(int x, int y) const { return pixels.data() + (size_t(y) * width + x) * 3; }
};

// A read-only view of pixels laid out as Image's (RGB float, rows top to
// bottom): an Image, or memory another owner keeps alive (a numpy array), so
// that a source is integrated where it lies instead of being copied. `rows`,
// when set, gives every row's start (some rows may then live elsewhere, e.g.
// cleaned copies of the few rows that held bad values); `data` is the
// contiguous original either way.
struct ImageView {
    const float* data = nullptr;
    int width = 0, height = 0;
    const float* const* rows = nullptr;

    ImageView() = default;
    ImageView(const float* d, int w, int h) : data(d), width(w), height(h) {}
    ImageView(const Image& img) : data(img.pixels.data()), width(img.width), height(img.height) {}  // NOLINT: implicit
    const float* at(int x, int y) const {
        return (rows ? rows[y] : data + size_t(y) * width * 3) + size_t(x) * 3;
    }
    size_t value_count() const { return size_t(width) * size_t(height) * 3; }
};

// Six square RGB faces in SPEC.md section 2's order, each face row-major with
// row j = t from the top. One storage block, one face table (math/cube.h).
struct Cubemap {
    int size = 0;
    std::vector<float> pixels;  // 6 * size * size * 3

    Cubemap() = default;
    explicit Cubemap(int n) : size(n), pixels(size_t(6) * n * n * 3, 0.0f) {}
    float* at(int face, int i, int j) { return pixels.data() + ((size_t(face) * size + j) * size + i) * 3; }
    const float* at(int face, int i, int j) const {
        return pixels.data() + ((size_t(face) * size + j) * size + i) * 3;
    }
};

// Lay a cube out as SPEC.md's horizontal cross (4N x 3N, unused cells black),
// as one interleaved RGBA buffer (alpha 1 on faces, 0 on unused cells): what
// the writers take, built without intermediate copies.
std::vector<float> cube_to_hcross_rgba(const Cubemap& cube);
// Rows y0 .. y0 + rows - 1 of that cross into `out` (rows * 4N * 4 floats),
// for writers that stream a file in bands instead of holding the whole cross.
void hcross_rgba_rows(const Cubemap& cube, int y0, int rows, float* out);
// The inverse, for readers and tests.
Cubemap hcross_to_cube(const Image& cross);

}  // namespace iblbake
