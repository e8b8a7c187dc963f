#include <algorithm>
#include <stdexcept>

#include "iblbake/image/image.h"
#include "iblbake/math/cube.h"

namespace iblbake {

std::vector<float> cube_to_hcross_rgba(const Cubemap& cube) {
    std::vector<float> out(size_t(4) * cube.size * 3 * cube.size * 4);
    hcross_rgba_rows(cube, 0, 3 * cube.size, out.data());
    return out;
}

void hcross_rgba_rows(const Cubemap& cube, int y0, int rows, float* out) {
    const size_t n = size_t(cube.size), w = 4 * n;
    std::fill(out, out + w * size_t(rows) * 4, 0.0f);
    for (int face = 0; face < 6; ++face) {
        const CrossCell cell = kHCrossCells[face];
        for (int y = std::max(y0, int(cell.row * n)); y < std::min(y0 + rows, int((cell.row + 1) * n)); ++y) {
            const size_t j = y - cell.row * n;
            float* d = &out[(size_t(y - y0) * w + cell.col * n) * 4];
            const float* s = cube.at(face, 0, int(j));
            for (size_t i = 0; i < n; ++i, d += 4, s += 3) {
                d[0] = s[0]; d[1] = s[1]; d[2] = s[2]; d[3] = 1.0f;
            }
        }
    }
}

Cubemap hcross_to_cube(const Image& cross) {
    if (cross.width % 4 != 0 || cross.height * 4 != cross.width * 3)
        throw std::invalid_argument("not a horizontal cross: width must be 4N and height 3N");
    const int n = cross.width / 4;
    Cubemap cube(n);
    for (int face = 0; face < 6; ++face) {
        const CrossCell cell = kHCrossCells[face];
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const float* s = cross.at(cell.col * n + i, cell.row * n + j);
                float* d = cube.at(face, i, j);
                d[0] = s[0]; d[1] = s[1]; d[2] = s[2];
            }
    }
    return cube;
}

}  // namespace iblbake
