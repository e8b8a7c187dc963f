// math: numbers and geometry (vectors, the cube and lat-long mappings, GGX,
// SH, quadrature), the lowest room with util/: it includes no other.
//
// Small 3-vector used by the math layer. Header-only, no I/O.
#pragma once
#include <cmath>

namespace iblbake {

template <typename T>
struct Vec3T {
    T x{}, y{}, z{};
    constexpr Vec3T() = default;
    constexpr Vec3T(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
    template <typename U>
    constexpr explicit Vec3T(const Vec3T<U>& o) : x(T(o.x)), y(T(o.y)), z(T(o.z)) {}

    constexpr Vec3T operator+(const Vec3T& o) const { return {x + o.x, y + o.y, z + o.z}; }
    constexpr Vec3T operator-(const Vec3T& o) const { return {x - o.x, y - o.y, z - o.z}; }
    constexpr Vec3T operator-() const { return {-x, -y, -z}; }
    constexpr Vec3T operator*(T s) const { return {x * s, y * s, z * s}; }
    constexpr Vec3T operator/(T s) const { return {x / s, y / s, z / s}; }
    Vec3T& operator+=(const Vec3T& o) { x += o.x; y += o.y; z += o.z; return *this; }
    Vec3T& operator*=(T s) { x *= s; y *= s; z *= s; return *this; }
    constexpr T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

using Vec3 = Vec3T<float>;
using Vec3d = Vec3T<double>;

template <typename T> constexpr Vec3T<T> operator*(T s, const Vec3T<T>& v) { return v * s; }
template <typename T> constexpr T dot(const Vec3T<T>& a, const Vec3T<T>& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <typename T> constexpr Vec3T<T> cross(const Vec3T<T>& a, const Vec3T<T>& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <typename T> inline T length(const Vec3T<T>& v) { return std::sqrt(dot(v, v)); }
template <typename T> inline Vec3T<T> normalize(const Vec3T<T>& v) { return v / length(v); }

// An orthonormal basis around n (Frisvad's construction, revised by
// Duff et al. 2017, "Building an Orthonormal Basis, Revisited"): no branch on
// a fixed "up" vector, so no seam where the seeds' cross(up, N) degenerates.
template <typename T>
inline void orthonormal_basis(const Vec3T<T>& n, Vec3T<T>& t, Vec3T<T>& b) {
    const T sign = std::copysign(T(1), n.z);
    const T a = T(-1) / (sign + n.z);
    const T c = n.x * n.y * a;
    t = {T(1) + sign * n.x * n.x * a, sign * c, -sign * n.x};
    b = {c, sign + n.y * n.y * a, -n.y};
}

constexpr double kPi = 3.14159265358979323846;

}  // namespace iblbake
