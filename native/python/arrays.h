// numpy <-> Image / Cubemap conversions shared by the bindings. Checks run
// with the GIL held; PixelArray::to_image() may run with it released (the
// checked array is kept alive by the PixelArray).
#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

#include "iblbake/image/image.h"

namespace iblbake::py {

[[noreturn]] void value_error(const std::string& msg);

// A float32 (H, W, 3|4) C-contiguous view of a numpy array, checked.
class PixelArray {
public:
    explicit PixelArray(const pybind11::handle& obj);  // raises ValueError on a wrong type, dtype or shape
    Image to_image() const;                             // RGB copy, alpha dropped; GIL not needed
    bool is_rgb() const { return ch_ == 3; }
    ImageView view() const { return {data_, w_, h_}; }  // only when is_rgb(); valid while this lives
    int width() const { return w_; }
    int height() const { return h_; }

private:
    pybind11::array_t<float, pybind11::array::c_style | pybind11::array::forcecast> arr_;
    const float* data_ = nullptr;
    int w_ = 0, h_ = 0, ch_ = 0;
};

pybind11::array_t<float> image_array(const Image& img);  // (H, W, 3)
pybind11::array_t<float> cube_array(const Cubemap& c);   // (6, N, N, 3)

}  // namespace iblbake::py
