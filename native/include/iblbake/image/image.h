// image: images and cubes in memory, the cross layout and display
// encodings. Above math/ and util/ only: it knows no integrator, no bake and
// no file.
//
// Image types: a lat-long or 2-D RGB float image and a cube of six faces.
// Plain storage, no I/O (that lives in io/).
#pragma once
#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

namespace iblbake {

// std::allocator whose value-initialisation (vector(n), resize(n)) leaves
// floats as they come: a buffer that is about to be written whole is not
// first zeroed by one thread (a 400 MB source or a 75 MB cube: a tenth of a
// second of page faults and memset on the critical path). Anything that
// needs zeros asks for them (Image(w, h) and Cubemap(n) still give zeros,
// filled in parallel). Tried and dropped: the large buffers in their own
// mappings offered to transparent huge pages. Back to back they made a
// default bake 4 % faster (20 600 page faults -> 13 500), but on this VM a
// bake started a few seconds after other work took 23 % longer: the host
// takes back free 2 MB blocks (free page reporting), and a huge page's first
// touch then costs the host's faults too.
template <typename T>
struct DefaultInitAllocator : std::allocator<T> {
    template <typename U>
    struct rebind {
        using other = DefaultInitAllocator<U>;
    };
    DefaultInitAllocator() = default;
    template <typename U>
    DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}  // NOLINT: implicit, as std::allocator's
    template <typename U>
    void construct(U* p) noexcept {
        ::new (static_cast<void*>(p)) U;
    }
    template <typename U, typename... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};
using FloatBuffer = std::vector<float, DefaultInitAllocator<float>>;
// Any large array whose every element is written before it is read.
template <typename T>
using BigVector = std::vector<T, DefaultInitAllocator<T>>;

// A read-only run of floats: what a writer takes, from either vector type.
struct FloatSpan {
    const float* data = nullptr;
    size_t size = 0;
    FloatSpan(const float* d, size_t n) : data(d), size(n) {}
    template <typename A>
    FloatSpan(const std::vector<float, A>& v) : data(v.data()), size(v.size()) {}  // NOLINT: implicit
};

// Tag for the constructors below: storage sized, its values left unset (the
// caller writes every one).
struct Uninitialized {};

// Whether every value is finite; whether any is NaN, infinite or beyond
// +-max_abs. Branch-free per block (vectorised), blocks on every core.
bool all_finite(FloatSpan values);
bool any_beyond(FloatSpan values, float max_abs);

// n zeros at p, written by every core when n is large (the pages are then
// first touched, and faulted in, in parallel).
void zero_fill(float* p, size_t n);

// RGB float image, rows top to bottom, pixels interleaved.
struct Image {
    int width = 0, height = 0;
    FloatBuffer pixels;  // width * height * 3

    Image() = default;
    Image(int w, int h) : Image(w, h, Uninitialized{}) { zero_fill(pixels.data(), pixels.size()); }
    Image(int w, int h, Uninitialized) : width(w), height(h), pixels(size_t(w) * size_t(h) * 3) {}
    float* at(int x, int y) { return pixels.data() + (size_t(y) * width + x) * 3; }
    const float* at(int x, int y) const { return pixels.data() + (size_t(y) * width + x) * 3; }
};

// Gives an image's rows back to the system from the top down as they stop
// being needed (the whole memory pages of the rows above `y`, madvise's
// MADV_DONTNEED), without freeing the image: those rows read as zeros after.
// For a source that the last reader of its rows goes through once, top to
// bottom (issue 25: the bin tree, its per-channel moments and the whole
// source were otherwise all held at the bake's peak). A no-op where the
// system has no such call.
class RowRelease {
public:
    explicit RowRelease(Image& img);
    void before(int y);                        // rows 0 .. y - 1 are never read again
    size_t released() const { return bytes_; }  // bytes given back so far

private:
    Image& img_;
    size_t done_ = 0;   // bytes from the first whole page already given back
    size_t first_ = 0;  // offset of the first whole page in the pixels, bytes
    size_t bytes_ = 0;
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
    FloatBuffer pixels;  // 6 * size * size * 3

    Cubemap() = default;
    explicit Cubemap(int n) : Cubemap(n, Uninitialized{}) { zero_fill(pixels.data(), pixels.size()); }
    Cubemap(int n, Uninitialized) : size(n), pixels(size_t(6) * n * n * 3) {}
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
