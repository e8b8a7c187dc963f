// A pyramid of exact lat-long bins (ibl/source.h) for hierarchical kernel
// sums: level 0 is the finest grid (w x w/2, w a power of two), each coarser
// level sums 2 x 2 bins exactly. Stored as floats, structure-of-arrays.
#pragma once
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/ibl/source.h"

namespace iblbake {

struct BinLevel {
    int w = 0, h = 0;
    // Power centroid (unit): where the bin's radiance sits, so a bright
    // texel inside a coarse bin is placed right to first order.
    std::vector<float> px, py, pz;
    // Solid-angle centroid (unit).
    std::vector<float> cx, cy, cz;
    // Power per channel and solid angle, each scaled by |first moment| /
    // zeroth moment (exact for kernels linear in n.w at the centroid).
    std::vector<float> power[3], omega;
    // Angular radius: the largest angle from the solid-angle centroid to the
    // bin's corners and edge midpoints (radians).
    std::vector<float> radius;
    size_t index(int x, int y) const { return size_t(y) * w + x; }
};

struct BinTree {
    std::vector<BinLevel> levels;  // [0] finest
};

// finest_w: bins across at level 0 (a power of two >= 2). With `keep`, the
// exact bins (ibl/source.h) at keep_w across (a power of two in 2..finest_w/4)
// are copied there on the way: another reduction of the same image for free.
BinTree build_bin_tree(ImageView latlong, int finest_w, std::vector<Bin>* keep = nullptr, int keep_w = 0);

}  // namespace iblbake
