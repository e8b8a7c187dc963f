// Geometry and image helpers for scripts and tests: the contract's mappings.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <array>
#include <cmath>
#include <cstring>
#include <utility>

#include "arrays.h"
#include "bindings.h"
#include "iblbake/export/sun.h"
#include "iblbake/ibl/source.h"
#include "iblbake/ibl/sun.h"
#include "iblbake/io/image_io.h"
#include "iblbake/math/cube.h"

namespace iblbake::py {

void bind_geometry(pybind11::module_& m) {
    m.def(
        "texel_direction",
        [](int face, int i, int j, int n) {
            if (face < 0 || face > 5 || n < 1 || i < 0 || j < 0 || i >= n || j >= n)
                throw pybind11::value_error("texel out of range");
            const Vec3d d = texel_direction(face, i, j, n);
            return pybind11::make_tuple(d.x, d.y, d.z);
        },
        "Engine-space (Y-up) unit direction of texel (i, j) of face `face` of an n x n cube.");
    m.def(
        "direction_to_face",
        [](double x, double y, double z) {
            if (x == 0 && y == 0 && z == 0) throw pybind11::value_error("zero direction");
            const FaceCoord fc = direction_to_face(Vec3d{x, y, z});
            return pybind11::make_tuple(fc.face, fc.s, fc.t);
        },
        "Face index and (s, t) in [0, 1] of an engine-space direction.");
    m.def(
        "image_format",
        [](const std::string& path) {
            const std::string f = io::image_format(path);
            return pybind11::make_tuple(f, io::reads_format(f));
        },
        pybind11::arg("path"),
        "(format, readable): the format read_image takes the file for (its first bytes, else its extension; '' "
        "for none), and whether this build reads it (OpenEXR, PNG and JPEG always; others through the "
        "OpenImageIO plugin, which the self-contained wheels do not carry).");
    m.def(
        "read_image",
        [](const std::string& path, bool info) -> pybind11::object {
            io::LoadedImage li;
            {
                pybind11::gil_scoped_release release;
                li = io::read_image(path);
            }
            pybind11::array_t<float> a({li.image.height, li.image.width, 3});
            float* dst = a.mutable_data();
            {  // a large image's copy must not hold the GIL (Blender's UI waits on it)
                pybind11::gil_scoped_release release;
                std::memcpy(dst, li.image.pixels.data(), li.image.pixels.size() * sizeof(float));
            }
            if (!info) return pybind11::object(std::move(a));
            pybind11::dict d;
            d["channels"] = li.source_channels;
            d["linearised"] = li.linearised;
            d["format"] = li.format;
            return pybind11::make_tuple(std::move(a), d);
        },
        pybind11::arg("path"), pybind11::arg("info") = false,
        "Read an image as the bake does: (H, W, 3) float32, linear. With info=True: (array, {'channels': as "
        "stored, 'linearised': an integer sRGB file was decoded, 'format': OpenImageIO's name}).");
    m.def(
        "write_exr",
        [](const std::string& path, const pybind11::handle& image) {
            const PixelArray pixels(image);
            pybind11::gil_scoped_release release;
            io::write_exr(path, pixels.to_image(), io::ExrPixel::Float);
        },
        pybind11::arg("path"), pybind11::arg("image"),
        "Write a (H, W, 3|4) float32 array (rows top-down, alpha dropped) as a zip-compressed full-float RGB EXR.");
    m.def(
        "remap_latlong",
        [](const pybind11::handle& image, const std::array<double, 9>& matrix, const std::array<double, 3>& offset) {
            const PixelArray pixels(image);
            for (double v : matrix)
                if (!std::isfinite(v)) value_error("matrix must be finite");
            for (double v : offset)
                if (!std::isfinite(v)) value_error("offset must be finite");
            Image out;
            {
                pybind11::gil_scoped_release release;
                out = remap_latlong(pixels.to_image(), matrix, offset);
            }
            return image_array(out);
        },
        pybind11::arg("image"), pybind11::arg("matrix"), pybind11::arg("offset") = std::array<double, 3>{0, 0, 0},
        "The lat-long image (H, W, 3|4) seen through the lookup d -> matrix @ d + offset (Blender directions,\n"
        "matrix row-major, 9 numbers), as a Mapping node feeding an Environment Texture: (H, W, 3), bilinear.");
    m.def(
        "split_sun",
        [](const pybind11::handle& image) {
            const PixelArray pixels(image);
            Image img = pixels.to_image();
            SunSplit split;
            {
                pybind11::gil_scoped_release release;
                sanitize(img);
                split = split_sun(img);
                apply_sun_split(img, split);
            }
            const std::string text = sun_json(split.light).dump();
            return pybind11::make_tuple(image_array(img), pybind11::module_::import("json").attr("loads")(text));
        },
        pybind11::arg("image"),
        "The sun as a light (issue 27; bake(sun='split') does the same inside a bake): (sun_free, sun) for a\n"
        "lat-long (H, W, 3|4) array, cleaned as a bake cleans it; sun_free is (H, W, 3) with the sun's texels\n"
        "replaced by the sky behind them, sun is sun.json's content (found, why, direction, ...).");
}

}  // namespace iblbake::py
