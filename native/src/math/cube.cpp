#include "iblbake/math/cube.h"

#include <cmath>

namespace iblbake {

// OpenGL specification, table "Selection of cube map images": dir = ma + s*sc + t*tc.
const std::array<FaceFrame, 6> kFaceFrames = {{
    {{+1, 0, 0}, {0, 0, -1}, {0, -1, 0}},  // +X
    {{-1, 0, 0}, {0, 0, +1}, {0, -1, 0}},  // -X
    {{0, +1, 0}, {+1, 0, 0}, {0, 0, +1}},  // +Y
    {{0, -1, 0}, {+1, 0, 0}, {0, 0, -1}},  // -Y
    {{0, 0, +1}, {+1, 0, 0}, {0, -1, 0}},  // +Z
    {{0, 0, -1}, {-1, 0, 0}, {0, -1, 0}},  // -Z
}};

//     .   +Y  .   .
//     -X  +Z  +X  -Z
//     .   -Y  .   .
const std::array<CrossCell, 6> kHCrossCells = {{
    {2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1},
}};

Vec3d texel_direction(int face, int i, int j, int n) {
    const double a = 2.0 * (i + 0.5) / n - 1.0;
    const double b = 2.0 * (j + 0.5) / n - 1.0;
    return normalize(face_point(face, a, b));
}

namespace {
template <typename T>
int major_face(T x, T y, T z, T& ma) {
    const T ax = std::fabs(x), ay = std::fabs(y), az = std::fabs(z);
    if (ax >= ay && ax >= az) { ma = ax; return x >= 0 ? 0 : 1; }
    if (ay >= az) { ma = ay; return y >= 0 ? 2 : 3; }
    ma = az;
    return z >= 0 ? 4 : 5;
}
}  // namespace

FaceCoord direction_to_face(const Vec3d& d) {
    double ma;
    const int face = major_face(d.x, d.y, d.z, ma);
    const FaceFrame& f = kFaceFrames[face];
    const double a = dot(d, f.s) / ma, b = dot(d, f.t) / ma;
    return {face, 0.5 * (a + 1.0), 0.5 * (b + 1.0)};
}

FaceCoordF direction_to_face(const Vec3& d) {
    float ma;
    const int face = major_face(d.x, d.y, d.z, ma);
    const FaceFrame& f = kFaceFrames[face];
    const Vec3 s(f.s), t(f.t);
    const float inv = 1.0f / ma;
    return {face, 0.5f * (dot(d, s) * inv + 1.0f), 0.5f * (dot(d, t) * inv + 1.0f)};
}

namespace {
double area_element(double a, double b) { return std::atan2(a * b, std::sqrt(a * a + b * b + 1.0)); }
}  // namespace

double face_rect_solid_angle(double a0, double b0, double a1, double b1) {
    return area_element(a0, b0) - area_element(a0, b1) - area_element(a1, b0) + area_element(a1, b1);
}

double texel_solid_angle(int i, int j, int n) {
    const double a0 = 2.0 * i / n - 1.0, a1 = 2.0 * (i + 1) / n - 1.0;
    const double b0 = 2.0 * j / n - 1.0, b1 = 2.0 * (j + 1) / n - 1.0;
    return face_rect_solid_angle(a0, b0, a1, b1);
}

}  // namespace iblbake
