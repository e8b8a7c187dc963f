#include <stdexcept>

#include "iblbake/image/image.h"
#include "iblbake/math/cube.h"

namespace iblbake {

Image cube_to_hcross(const Cubemap& cube, std::vector<float>* alpha) {
    const int n = cube.size;
    Image cross(4 * n, 3 * n);
    if (alpha) alpha->assign(size_t(cross.width) * cross.height, 0.0f);
    for (int face = 0; face < 6; ++face) {
        const CrossCell cell = kHCrossCells[face];
        for (int j = 0; j < n; ++j) {
            const int y = cell.row * n + j;
            for (int i = 0; i < n; ++i) {
                const int x = cell.col * n + i;
                const float* s = cube.at(face, i, j);
                float* d = cross.at(x, y);
                d[0] = s[0]; d[1] = s[1]; d[2] = s[2];
                if (alpha) (*alpha)[size_t(y) * cross.width + x] = 1.0f;
            }
        }
    }
    return cross;
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
