// Cube-map geometry of SPEC.md section 2: one face table, engine (Y-up)
// directions, texel centres, exact texel solid angles. No I/O.
#pragma once
#include <array>
#include <cstdint>

#include "iblbake/math/vec3.h"

namespace iblbake {

enum class Face : int { PosX = 0, NegX = 1, PosY = 2, NegY = 3, PosZ = 4, NegZ = 5 };

// Per face: major axis, the axis s (= sc/|ma|) runs along, the axis t (= tc/|ma|)
// runs along (OpenGL specification's table; s left to right, t top to bottom).
struct FaceFrame {
    Vec3d ma, s, t;
};
extern const std::array<FaceFrame, 6> kFaceFrames;

// Cells of the horizontal cross (column, row) in units of the face size.
struct CrossCell { int col, row; };
extern const std::array<CrossCell, 6> kHCrossCells;

// Blender world (Z-up) <-> engine (Y-up): D = (x, z, -y).
template <typename T> constexpr Vec3T<T> blender_to_engine(const Vec3T<T>& b) { return {b.x, b.z, -b.y}; }
template <typename T> constexpr Vec3T<T> engine_to_blender(const Vec3T<T>& e) { return {e.x, -e.z, e.y}; }

// Unnormalised engine direction through face coordinates a = 2s-1, b = 2t-1.
inline Vec3d face_point(int face, double a, double b) {
    const FaceFrame& f = kFaceFrames[face];
    return f.ma + f.s * a + f.t * b;
}

// Unit engine direction of the centre of texel (i, j) of an n x n face.
Vec3d texel_direction(int face, int i, int j, int n);

// Where a direction lands: face and s, t in [0, 1].
struct FaceCoord { int face; double s, t; };
FaceCoord direction_to_face(const Vec3d& d);
// Single-precision twin for the hot loops (same tie rule: x before y before z).
struct FaceCoordF { int face; float s, t; };
FaceCoordF direction_to_face(const Vec3& d);

// Exact solid angle of the face rectangle [a0, a1] x [b0, b1] (face coordinates
// in [-1, 1]), via the area element atan2(ab, sqrt(a^2 + b^2 + 1)) evaluated in
// double so it stays exact at 2048^2 faces.
double face_rect_solid_angle(double a0, double b0, double a1, double b1);
double texel_solid_angle(int i, int j, int n);

}  // namespace iblbake
