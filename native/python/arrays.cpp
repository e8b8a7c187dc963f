#include "arrays.h"

#include <cstring>
#include <string>

#include "iblbake/io/image_io.h"

namespace iblbake::py {

void value_error(const std::string& msg) { throw pybind11::value_error(msg); }

PixelArray::PixelArray(const pybind11::handle& obj) {
    if (!pybind11::isinstance<pybind11::array>(obj)) value_error("image must be a numpy array");
    const auto arr = pybind11::reinterpret_borrow<pybind11::array>(obj);
    if (!arr.dtype().is(pybind11::dtype::of<float>()))
        value_error("image must be float32, got " + std::string(pybind11::str(arr.dtype())));
    if (arr.ndim() != 3 || (arr.shape(2) != 3 && arr.shape(2) != 4))
        value_error("image must have shape (H, W, 3) or (H, W, 4), got " + std::string(pybind11::str(arr.attr("shape"))));
    if (arr.shape(0) < 1 || arr.shape(1) < 1) value_error("image must be at least 1 x 1");
    // The same maximum as a file's, before anything is copied (and before H
    // and W are narrowed to int).
    const int64_t h = arr.shape(0), w = arr.shape(1);
    if (w > io::kMaxSourceSide || h > io::kMaxSourceSide || w * h > io::kMaxSourcePixels)
        value_error("image is " + std::to_string(h) + " x " + std::to_string(w) +
                    " (H x W): larger than the maximum of 32768 x 16384 pixels (W x H) and " +
                    std::to_string(io::kMaxSourceSide) + " on a side");
    // A strided or broadcast array is copied to C order; numpy may fail to.
    arr_ = decltype(arr_)::ensure(arr);
    if (!arr_) {
        PyErr_Clear();
        throw pybind11::value_error("image could not be copied to a C-contiguous float32 array (out of memory?)");
    }
    data_ = arr_.data();
    h_ = int(arr_.shape(0));
    w_ = int(arr_.shape(1));
    ch_ = int(arr_.shape(2));
}

Image PixelArray::to_image() const {
    Image img(w_, h_);
    const size_t n = size_t(w_) * h_;
    if (ch_ == 3) {
        std::memcpy(img.pixels.data(), data_, n * 3 * sizeof(float));
    } else {
        for (size_t p = 0; p < n; ++p)
            for (int k = 0; k < 3; ++k) img.pixels[p * 3 + k] = data_[p * ch_ + k];
    }
    return img;
}

pybind11::array_t<float> image_array(const Image& img) {
    pybind11::array_t<float> a({img.height, img.width, 3});
    std::memcpy(a.mutable_data(), img.pixels.data(), img.pixels.size() * sizeof(float));
    return a;
}

pybind11::array_t<float> cube_array(const Cubemap& c) {
    pybind11::array_t<float> a({6, c.size, c.size, 3});
    std::memcpy(a.mutable_data(), c.pixels.data(), c.pixels.size() * sizeof(float));
    return a;
}

}  // namespace iblbake::py
