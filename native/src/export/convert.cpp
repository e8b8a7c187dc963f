#include "iblbake/export/convert.h"

#include <algorithm>

namespace iblbake {

namespace {
constexpr int kPosX = 0, kNegX = 1, kPosY = 2, kNegY = 3, kPosZ = 4, kNegZ = 5;
}

// From the face table (SPEC section 2): +X = (1, -t, -s), -X = (-1, -t, s),
// +Y = (s, 1, t), -Y = (s, -1, -t), +Z = (s, -t, 1), -Z = (-s, -t, -1) for
// s, t in [-1, 1]. Negating X swaps +X and -X and flips s on every face;
// negating Z swaps +Z and -Z, flips s on the X and Z faces and t on the Y faces.
TexelRef mirror_source(Mirror m, int face, int i, int j, int n) {
    switch (m) {
        case Mirror::None: return {face, i, j};
        case Mirror::X: {
            const int g = face == kPosX ? kNegX : face == kNegX ? kPosX : face;
            return {g, n - 1 - i, j};
        }
        case Mirror::Z: {
            const int g = face == kPosZ ? kNegZ : face == kNegZ ? kPosZ : face;
            if (face == kPosY || face == kNegY) return {g, i, n - 1 - j};
            return {g, n - 1 - i, j};
        }
    }
    return {face, i, j};
}

Cubemap mirror_cube(const Cubemap& cube, Mirror m) {
    if (m == Mirror::None) return cube;
    Cubemap out(cube.size);
    const int n = cube.size;
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const TexelRef s = mirror_source(m, f, i, j, n);
                std::copy_n(cube.at(s.face, s.i, s.j), 3, out.at(f, i, j));
            }
    return out;
}

RowSource mirrored_row(const Cubemap& cube, Mirror m, int face, int j) {
    const int n = cube.size;
    const TexelRef a = mirror_source(m, face, 0, j, n);
    if (n == 1) return {cube.at(a.face, a.i, a.j), 3};
    const TexelRef b = mirror_source(m, face, 1, j, n);
    return {cube.at(a.face, a.i, a.j), b.i > a.i ? std::ptrdiff_t(3) : std::ptrdiff_t(-3)};
}

Sh9 mirror_sh9(const Sh9& sh, Mirror m) {
    Sh9 out = sh;
    if (m == Mirror::X)
        for (int i : {3, 4, 7}) out[i] = -out[i];
    if (m == Mirror::Z)
        for (int i : {2, 5, 7}) out[i] = -out[i];
    return out;
}

std::array<Sh9, 3> mirror_sh9(const std::array<Sh9, 3>& sh, Mirror m) {
    return {mirror_sh9(sh[0], m), mirror_sh9(sh[1], m), mirror_sh9(sh[2], m)};
}

const std::array<double, 9> kIrradianceShScale = [] {
    // The basis constants of math/sh.h (its value at a direction with the
    // polynomial part 1) times the band's cosine-lobe factor A_l / pi.
    const std::array<double, 9> c = {0.282095, 0.488603, 0.488603, 0.488603, 1.092548,
                                     1.092548, 0.315392, 1.092548, 0.546274};
    std::array<double, 9> k{};
    for (int i = 0; i < 9; ++i) k[i] = c[i] * sh9_band_factor(i);
    return k;
}();

std::array<Sh9, 3> filament_sh(const std::array<Sh9, 3>& sh9) {
    std::array<Sh9, 3> out{};
    for (int c = 0; c < 3; ++c)
        for (int i = 0; i < 9; ++i) out[c][i] = sh9[c][i] * kIrradianceShScale[i];
    return out;
}

Polynomial babylon_polynomial(const std::array<Sh9, 3>& sh9) {
    const auto& k = kIrradianceShScale;
    // Babylon renders a SphericalPolynomial through SphericalHarmonics::FromPolynomial
    // and its pre-scaled basis, which (relative to band 0) multiplies band 1 by 3/2
    // and band 2 by 4: its own cube -> polynomial path applies the cosine-lobe factors
    // twice. So band l is stored times A_l / pi (1, 2/3, 1/4) and Babylon shows Irr
    // (measured by the engine tests, tests/engines/engine_babylon.mjs).
    constexpr double kBabylonBand[9] = {1.0, 2.0 / 3, 2.0 / 3, 2.0 / 3, 0.25, 0.25, 0.25, 0.25, 0.25};
    Polynomial p{};
    for (int c = 0; c < 3; ++c) {
        Sh9 L = sh9[c];
        for (int i = 0; i < 9; ++i) L[i] *= kBabylonBand[i];
        const double constant = k[0] * L[0] - k[6] * L[6];  // times x^2 + y^2 + z^2 = 1
        p.x[c] = k[3] * L[3];
        p.y[c] = k[1] * L[1];
        p.z[c] = k[2] * L[2];
        p.xx[c] = constant + k[8] * L[8];
        p.yy[c] = constant - k[8] * L[8];
        p.zz[c] = constant + 3.0 * k[6] * L[6];
        p.xy[c] = k[4] * L[4];
        p.yz[c] = k[5] * L[5];
        p.zx[c] = k[7] * L[7];
    }
    return p;
}

std::array<double, 3> evaluate(const Polynomial& p, const Vec3d& n) {
    std::array<double, 3> out{};
    for (int c = 0; c < 3; ++c)
        out[c] = p.x[c] * n.x + p.y[c] * n.y + p.z[c] * n.z + p.xx[c] * n.x * n.x + p.yy[c] * n.y * n.y +
                 p.zz[c] * n.z * n.z + p.yz[c] * n.y * n.z + p.zx[c] * n.z * n.x + p.xy[c] * n.x * n.y;
    return out;
}

}  // namespace iblbake
