// A pyramid of exact lat-long bins (ibl/source.h: integrals of SPEC's
// bilinear L) for hierarchical kernel sums: level 0 is the finest grid
// (w x w/2, w a power of two), each coarser level sums 2 x 2 bins exactly.
// Each bin keeps the zeroth, first and second moments of its radiance, as
// floats, structure-of-arrays.
#pragma once
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/ibl/source.h"

namespace iblbake {

// One bin as the hierarchical sum reads it, in one cache line.
struct alignas(64) BinNode {
    // Where the bin's radiance sits: m = integral of L w dOmega / integral of
    // L dOmega (channel sums), kept as its unit direction p and g = 1 - |m|,
    // so that 1 - n.m = g + (1 - g) |n - p|^2 / 2 without cancellation.
    float px, py, pz, g;
    // Power per channel: integral of L_c dOmega.
    float power[3];
    // Covariance of w under the bin's radiance (channel sums), engine space:
    // xx, yy, zz, xy, xz, yz. n^T C n is the variance of n.w over the bin.
    float cov[6];
    // Angular radius about p: the largest angle from p to the bin's corners
    // and edge midpoints (radians); negative for a bin with no radiance.
    float radius;
    float unused[2];
};
static_assert(sizeof(BinNode) == 64, "a bin is one cache line");

struct BinLevel {
    int w = 0, h = 0;
    BigVector<BinNode> nodes;  // every node written by the builder
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
