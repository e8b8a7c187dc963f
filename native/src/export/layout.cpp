#include "iblbake/export/layout.h"

#include <algorithm>
#include <stdexcept>

#include "iblbake/math/cube.h"
#include "iblbake/math/latlong.h"

namespace iblbake {

const char* const kFaceSuffixes[6] = {"px", "nx", "py", "ny", "pz", "nz"};

const char* layout_name(CubeLayout l) {
    switch (l) {
        case CubeLayout::HCross: return "hcross";
        case CubeLayout::VCross: return "vcross";
        case CubeLayout::Faces: return "faces";
        case CubeLayout::LatLong: return "latlong";
    }
    return "?";
}

CubeLayout layout_from_name(const std::string& name) {
    for (CubeLayout l : {CubeLayout::HCross, CubeLayout::VCross, CubeLayout::Faces, CubeLayout::LatLong})
        if (name == layout_name(l)) return l;
    throw std::invalid_argument("unknown layout '" + name + "' (expected hcross, vcross, faces or latlong)");
}

void vcross_rgba_rows(const Cubemap& cube, int y0, int rows, float* out) {
    // (column, row) of each face in units of N, and whether it is turned 180 degrees.
    static const int kCells[6][3] = {{2, 1, 0}, {0, 1, 0}, {1, 0, 0}, {1, 2, 0}, {1, 1, 0}, {1, 3, 1}};
    const size_t n = size_t(cube.size), w = 3 * n;
    std::fill(out, out + w * size_t(rows) * 4, 0.0f);
    for (int face = 0; face < 6; ++face) {
        const int col = kCells[face][0], row = kCells[face][1];
        const bool turned = kCells[face][2] != 0;
        for (int y = std::max(y0, int(row * n)); y < std::min(y0 + rows, int((row + 1) * n)); ++y) {
            const int j = int(y - row * n);
            float* d = &out[(size_t(y - y0) * w + col * n) * 4];
            for (size_t i = 0; i < n; ++i, d += 4) {
                const float* s = turned ? cube.at(face, int(n - 1 - i), int(n) - 1 - j) : cube.at(face, int(i), j);
                d[0] = s[0]; d[1] = s[1]; d[2] = s[2]; d[3] = 1.0f;
            }
        }
    }
}

void face_rgba_rows(const Cubemap& cube, int face, int y0, int rows, float* out) {
    const int n = cube.size;
    for (int y = y0; y < y0 + rows; ++y) {
        const float* s = cube.at(face, 0, y);
        float* d = out + size_t(y - y0) * n * 4;
        for (int i = 0; i < n; ++i, s += 3, d += 4) {
            d[0] = s[0]; d[1] = s[1]; d[2] = s[2]; d[3] = 1.0f;
        }
    }
}

void latlong_rgba_rows(const BorderedCube& cube, int w, int h, int y0, int rows, float* out) {
    for (int y = y0; y < y0 + rows; ++y)
        for (int x = 0; x < w; ++x) {
            const Vec3 d(blender_to_engine(latlong_texel_direction(x, y, w, h)));
            float* o = out + (size_t(y - y0) * w + x) * 4;
            cube.bilinear(d, o);
            o[3] = 1.0f;
        }
}

}  // namespace iblbake
