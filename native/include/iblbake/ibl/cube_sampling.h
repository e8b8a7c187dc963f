// Seam-free bilinear and trilinear lookups on cubes: every face carries a
// one-texel border copied from its neighbours, so a bilinear footprint never
// leaves its face (the approach of Filament's libs/ibl, where it is used to
// make face edges continuous).
#pragma once
#include <vector>

#include "iblbake/image/image.h"
#include "iblbake/math/cube.h"

namespace iblbake {

class BorderedCube {
public:
    BorderedCube() = default;
    explicit BorderedCube(int n);
    static BorderedCube from_cube(const Cubemap& cube);  // copies faces, fills borders

    int size() const { return n_; }
    // i, j in [-1, n]: -1 and n are the border.
    float* at(int face, int i, int j) { return data_.data() + index(face, i, j); }
    const float* at(int face, int i, int j) const { return data_.data() + index(face, i, j); }
    void fill_borders();
    void bilinear(const FaceCoordF& fc, float out[3]) const;
    void bilinear(const Vec3& engine_dir, float out[3]) const { bilinear(direction_to_face(engine_dir), out); }

private:
    size_t index(int face, int i, int j) const {
        const int s = n_ + 2;
        return ((size_t(face) * s + (j + 1)) * s + (i + 1)) * 3;
    }
    int n_ = 0;
    std::vector<float> data_;
};

// A mip pyramid of bordered cubes, base size a power of two down to 1.
// Each parent texel is the solid-angle-weighted mean of its four children.
struct CubePyramid {
    std::vector<BorderedCube> levels;
    int base_size() const { return levels.empty() ? 0 : levels[0].size(); }
    // Trilinear lookup at (clamped) fractional level `lod`.
    void trilinear(const Vec3& engine_dir, float lod, float out[3]) const;
};
CubePyramid build_pyramid(const Cubemap& base);

// Resample a lat-long image onto a cube: each texel is the mean of ss x ss
// bilinear lookups of L (SPEC.md section 1) spread over the texel.
void latlong_to_cube(Cubemap& dst, ImageView latlong, int supersample);

}  // namespace iblbake
