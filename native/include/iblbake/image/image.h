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
// The inverse, for readers and tests.
Cubemap hcross_to_cube(const Image& cross);

}  // namespace iblbake
