#include "iblbake/pipeline/preview.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>

#include "iblbake/math/cube.h"
#include "iblbake/math/vec3.h"

namespace iblbake {

namespace {

// --- a 5 x 7 bitmap font (rows top-down, bit 4 = leftmost column) ------------
struct Glyph {
    char c;
    uint8_t rows[7];
};
constexpr Glyph kFont[] = {
    {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}}, {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}}, {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
    {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}}, {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
    {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}}, {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}}, {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
    {'A', {0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11}}, {'B', {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E}},
    {'C', {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E}}, {'D', {0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C}},
    {'E', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F}}, {'F', {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10}},
    {'G', {0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F}}, {'H', {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11}},
    {'I', {0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}}, {'J', {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C}},
    {'K', {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}}, {'L', {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F}},
    {'M', {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11}}, {'N', {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11}},
    {'O', {0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}}, {'P', {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10}},
    {'Q', {0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D}}, {'R', {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11}},
    {'S', {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E}}, {'T', {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}},
    {'U', {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}}, {'V', {0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04}},
    {'W', {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A}}, {'X', {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11}},
    {'Y', {0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04}}, {'Z', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}}, {'=', {0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00}},
    {'-', {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00}}, {':', {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00}},
    {'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}}, {'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}},
    {')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}},
};

constexpr int kTextScale = 2;
constexpr int kGlyphAdvance = 6 * kTextScale;
constexpr int kLabel = 7 * kTextScale + 8;  // a label line's height
constexpr int kMargin = 12, kGap = 8;
constexpr float kBackground = 0.015f;          // display-linear
constexpr float kPanel = 0.035f;               // behind unused cross cells and spheres
constexpr float kText = 0.85f;

const Glyph* glyph(char c) {
    const char u = char(std::toupper(static_cast<unsigned char>(c)));
    for (const Glyph& g : kFont)
        if (g.c == u) return &g;
    return nullptr;
}

void put(Image& img, int x, int y, const std::array<float, 3>& c) {
    if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
    float* p = img.at(x, y);
    p[0] = c[0], p[1] = c[1], p[2] = c[2];
}

void fill_rect(Image& img, int x0, int y0, int w, int h, float v) {
    for (int y = y0; y < y0 + h; ++y)
        for (int x = x0; x < x0 + w; ++x) put(img, x, y, {v, v, v});
}

void draw_text(Image& img, int x, int y, const std::string& s) {
    for (char c : s) {
        if (const Glyph* g = glyph(c))
            for (int r = 0; r < 7; ++r)
                for (int col = 0; col < 5; ++col)
                    if (g->rows[r] & (0x10 >> col))
                        for (int dy = 0; dy < kTextScale; ++dy)
                            for (int dx = 0; dx < kTextScale; ++dx)
                                put(img, x + col * kTextScale + dx, y + r * kTextScale + dy, {kText, kText, kText});
        x += kGlyphAdvance;
    }
}

// A specular level's column: "4: 0.5", its level and roughness (the row's heading says which is which).
std::string level_label(int level, double r) {
    char buf[48];
    std::snprintf(buf, sizeof(buf), "%d: %.3g", level, r);
    return buf;
}

// One texel, where (i, j) may lie one texel outside the face: such a texel
// is the one of the neighbouring face that its centre's direction reaches.
const float* texel(const Cubemap& cube, int face, int i, int j) {
    const int n = cube.size;
    if (i >= 0 && j >= 0 && i < n && j < n) return cube.at(face, i, j);
    const Vec3d d = face_point(face, 2.0 * (i + 0.5) / n - 1.0, 2.0 * (j + 0.5) / n - 1.0);
    const FaceCoord fc = direction_to_face(d);
    const int x = std::clamp(int(fc.s * n), 0, n - 1), y = std::clamp(int(fc.t * n), 0, n - 1);
    return cube.at(fc.face, x, y);
}

// Bilinear lookup across face edges (as an engine's seamless cube filtering).
std::array<float, 3> cube_lookup(const Cubemap& cube, const Vec3d& d) {
    const FaceCoord fc = direction_to_face(d);
    const int n = cube.size;
    const double fx = fc.s * n - 0.5, fy = fc.t * n - 0.5;
    const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
    const double ax = fx - x0, ay = fy - y0;
    const float* p00 = texel(cube, fc.face, x0, y0);
    const float* p10 = texel(cube, fc.face, x0 + 1, y0);
    const float* p01 = texel(cube, fc.face, x0, y0 + 1);
    const float* p11 = texel(cube, fc.face, x0 + 1, y0 + 1);
    std::array<float, 3> out{};
    for (int c = 0; c < 3; ++c)
        out[c] = float((p00[c] * (1 - ax) + p10[c] * ax) * (1 - ay) + (p01[c] * (1 - ax) + p11[c] * ax) * ay);
    return out;
}

// The baked LUT at (NdotV, roughness): texel centres at (i + 0.5) / N, rows
// of roughness from the top (the manifest's axes), bilinear, clamped.
std::array<float, 2> lut_lookup(const Image& lut, double ndotv, double rough) {
    const double fx = std::clamp(ndotv * lut.width - 0.5, 0.0, lut.width - 1.0);
    const double fy = std::clamp(rough * lut.height - 0.5, 0.0, lut.height - 1.0);
    const int x0 = int(fx), y0 = int(fy);
    const int x1 = std::min(x0 + 1, lut.width - 1), y1 = std::min(y0 + 1, lut.height - 1);
    const double ax = fx - x0, ay = fy - y0;
    std::array<float, 2> out{};
    for (int c = 0; c < 2; ++c) {
        const double top = lut.at(x0, y0)[c] * (1 - ax) + lut.at(x1, y0)[c] * ax;
        const double bottom = lut.at(x0, y1)[c] * (1 - ax) + lut.at(x1, y1)[c] * ax;
        out[c] = float(top * (1 - ay) + bottom * ay);
    }
    return out;
}

// A cube as a horizontal cross, w = 4 f pixels wide: each pixel the mean of
// the texels whose centres fall in it (at least the nearest one).
void draw_cross(Image& img, int x0, int y0, int w, const Cubemap& cube, double scale) {
    const int f = std::max(1, w / 4), n = cube.size;
    fill_rect(img, x0, y0, 4 * f, 3 * f, kPanel);
    for (int face = 0; face < 6; ++face) {
        const CrossCell cell = kHCrossCells[face];
        for (int py = 0; py < f; ++py) {
            const int t0 = int(std::floor(double(py) * n / f)), t1 = std::max(t0 + 1, int(std::floor(double(py + 1) * n / f)));
            for (int px = 0; px < f; ++px) {
                const int s0 = int(std::floor(double(px) * n / f)), s1 = std::max(s0 + 1, int(std::floor(double(px + 1) * n / f)));
                double sum[3] = {0, 0, 0};
                for (int j = t0; j < std::min(t1, n); ++j)
                    for (int i = s0; i < std::min(s1, n); ++i)
                        for (int c = 0; c < 3; ++c) sum[c] += cube.at(face, i, j)[c];
                const double k = scale / double((std::min(t1, n) - t0) * (std::min(s1, n) - s0));
                put(img, x0 + cell.col * f + px, y0 + cell.row * f + py,
                    {preview_tone(float(sum[0] * k)), preview_tone(float(sum[1] * k)), preview_tone(float(sum[2] * k))});
            }
        }
    }
}

void draw_lut(Image& img, int x0, int y0, int size, const Image& lut) {
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            const auto ab = lut_lookup(lut, (x + 0.5) / size, (y + 0.5) / size);
            put(img, x0 + x, y0 + y, {ab[0], ab[1], 0.0f});
        }
}

// A sphere in a size x size square, 2 x 2 samples per pixel blended with
// the panel colour at the edge. shade(n, v) gives linear radiance.
template <typename Shade>
void draw_sphere(Image& img, int x0, int y0, int size, double scale, const Shade& shade) {
    const double radius = size / 2.0 - 4.0, cx = x0 + size / 2.0, cy = y0 + size / 2.0;
    const Vec3d v{0.0, 0.0, 1.0};
    for (int y = y0; y < y0 + size; ++y)
        for (int x = x0; x < x0 + size; ++x) {
            double sum[3] = {0, 0, 0};
            int inside = 0;
            for (int sy = 0; sy < 2; ++sy)
                for (int sx = 0; sx < 2; ++sx) {
                    const double px = (x + 0.25 + 0.5 * sx - cx) / radius;
                    const double py = -(y + 0.25 + 0.5 * sy - cy) / radius;
                    const double rr = px * px + py * py;
                    if (rr >= 1.0) continue;
                    const auto c = shade(Vec3d{px, py, std::sqrt(1.0 - rr)}, v);
                    for (int k = 0; k < 3; ++k) sum[k] += c[k];
                    ++inside;
                }
            const double cover = inside / 4.0;
            std::array<float, 3> out;
            for (int k = 0; k < 3; ++k)
                out[k] = float((inside ? preview_tone(float(sum[k] / inside * scale)) : 0.0) * cover + kPanel * (1.0 - cover));
            put(img, x, y, out);
        }
}

struct Layout {
    int cell, cross_w, cross_h, head_h, width, height;
    int y_spec, y_metal, y_diel;
    int lut_x, diffuse_x;
};

Layout layout_of(const BakeResult& r, const PreviewOptions& o) {
    Layout l{};
    l.cell = std::max(32, o.cell);
    const int big = l.cell * 3 / 2;
    l.cross_w = l.cell;
    l.cross_h = l.cell * 3 / 4;
    l.head_h = kLabel + big;
    l.lut_x = kMargin + 2 * l.cell + kGap * 2;
    l.diffuse_x = l.lut_x + big + kGap * 2;
    const int head_w = l.diffuse_x + big + kMargin;
    const int n = int(r.specular.size());
    const int spec_w = 2 * kMargin + n * l.cell + std::max(0, n - 1) * kGap;
    l.width = std::max(head_w, spec_w);
    l.y_spec = kMargin + l.head_h + 2 * kGap;
    l.y_metal = l.y_spec + kLabel * 2 + l.cross_h + kGap;
    l.y_diel = l.y_metal + kLabel + l.cell + kGap;
    l.height = n ? l.y_diel + kLabel + l.cell + kMargin : l.y_spec;
    return l;
}

int column_x(const Layout& l, size_t k) { return kMargin + int(k) * (l.cell + kGap); }

}  // namespace

std::array<float, 2> env_brdf_approx(float ndotv, float roughness) {
    const float c0[4] = {-1.0f, -0.0275f, -0.572f, 0.022f}, c1[4] = {1.0f, 0.0425f, 1.04f, -0.04f};
    float rr[4];
    for (int k = 0; k < 4; ++k) rr[k] = roughness * c0[k] + c1[k];
    const float a004 = std::min(rr[0] * rr[0], std::exp2(-9.28f * ndotv)) * rr[0] + rr[1];
    return {-1.04f * a004 + rr[2], 1.04f * a004 + rr[3]};
}

double preview_scale(const BakeResult& r, const PreviewOptions& o) {
    const double stops = std::exp2(double(o.exposure_stops));
    auto luminance = [](const float* p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; };
    if (r.irradiance && !r.irradiance->pixels.empty()) {  // a white diffuse surface lands at `key`
        double sum = 0.0;
        const size_t count = r.irradiance->pixels.size() / 3;
        for (size_t k = 0; k < count; ++k) sum += std::max(0.0, luminance(&r.irradiance->pixels[3 * k]));
        const double mean = sum / double(count);
        return (mean > 1e-6 && std::isfinite(mean) ? o.key / mean : 1.0) * stops;
    }
    if (r.specular.empty() || r.specular.front().pixels.empty()) return stops;
    constexpr double kFloor = 1e-4;  // else the log-average of the sharpest level (a sun barely moves it)
    const Cubemap& cube = r.specular.front();
    double sum = 0.0;
    const size_t count = cube.pixels.size() / 3;
    for (size_t k = 0; k < count; ++k) sum += std::log(kFloor + std::max(0.0, luminance(&cube.pixels[3 * k])));
    const double log_avg = std::exp(sum / double(count));
    return (log_avg > 2.0 * kFloor && std::isfinite(log_avg) ? o.key / log_avg : 1.0) * stops;
}

float preview_tone(float x) {
    constexpr float kWhite2 = 16.0f;  // Reinhard's curve with a white point of 4: near linear below 0.3
    x = std::max(0.0f, x);
    return x * (1.0f + x / kWhite2) / (1.0f + x);
}

std::array<float, 3> shade_sphere(const BakeResult& r, size_t level, const std::array<double, 3>& n_in,
                                  const std::array<double, 3>& v_in, bool metal) {
    const Vec3d n{n_in[0], n_in[1], n_in[2]}, v{v_in[0], v_in[1], v_in[2]};
    const double ndotv = std::clamp(dot(n, v), 1e-4, 1.0);
    const Vec3d refl = n * (2.0 * dot(n, v)) - v;
    const double rough = r.roughness.at(level);
    const std::array<float, 3> pre = cube_lookup(r.specular.at(level), refl);
    const std::array<float, 2> ab = r.lut ? lut_lookup(*r.lut, ndotv, rough) : env_brdf_approx(float(ndotv), float(rough));
    std::array<float, 3> out{};
    if (metal) {
        for (int c = 0; c < 3; ++c) out[c] = pre[c] * (kPreviewMetalF0[c] * ab[0] + ab[1]);
        return out;
    }
    const float spec = kPreviewDielectricF0 * ab[0] + ab[1];
    const std::array<float, 3> irr = r.irradiance ? cube_lookup(*r.irradiance, n) : std::array<float, 3>{0, 0, 0};
    for (int c = 0; c < 3; ++c) out[c] = kPreviewAlbedo * irr[c] * (1.0f - spec) + pre[c] * spec;
    return out;
}

SphereSpot preview_sphere_spot(const BakeResult& r, size_t level, bool metal, const PreviewOptions& o) {
    const Layout l = layout_of(r, o);
    SphereSpot s;
    s.cx = column_x(l, level) + l.cell / 2;
    s.cy = (metal ? l.y_metal : l.y_diel) + kLabel + l.cell / 2;
    s.radius = l.cell / 2 - 4;
    return s;
}

Image render_preview(const BakeResult& r, const PreviewOptions& o) {
    const Layout l = layout_of(r, o);
    const double scale = preview_scale(r, o);
    Image img(l.width, l.height);
    fill_rect(img, 0, 0, l.width, l.height, kBackground);
    const int big = l.cell * 3 / 2;

    // Header: irradiance, LUT, a diffuse sphere.
    draw_text(img, kMargin, kMargin, "IRRADIANCE");
    if (r.irradiance) draw_cross(img, kMargin, kMargin + kLabel, 2 * l.cell, *r.irradiance, scale);
    else draw_text(img, kMargin, kMargin + kLabel + 8, "NOT BAKED");
    draw_text(img, l.lut_x, kMargin, "BRDF LUT");
    if (r.lut) draw_lut(img, l.lut_x, kMargin + kLabel, big, *r.lut);
    else draw_text(img, l.lut_x, kMargin + kLabel + 8, "NOT BAKED");
    if (r.irradiance) {
        draw_text(img, l.diffuse_x, kMargin, "DIFFUSE");
        const Cubemap& irr = *r.irradiance;
        draw_sphere(img, l.diffuse_x, kMargin + kLabel, big, scale, [&](const Vec3d& n, const Vec3d&) {
            const auto e = cube_lookup(irr, n);
            return std::array<float, 3>{kPreviewAlbedo * e[0], kPreviewAlbedo * e[1], kPreviewAlbedo * e[2]};
        });
    }
    if (r.specular.empty()) return img;

    // Specular levels, then the spheres at each level's roughness.
    draw_text(img, kMargin, l.y_spec, "SPECULAR LEVEL: ROUGHNESS");
    draw_text(img, kMargin, l.y_metal, "METAL");
    draw_text(img, kMargin, l.y_diel, "DIELECTRIC");
    for (size_t k = 0; k < r.specular.size(); ++k) {
        const int x = column_x(l, k);
        const int level = k < r.specular_levels.size() ? r.specular_levels[k] : int(k);
        draw_text(img, x, l.y_spec + kLabel, level_label(level, r.roughness.at(k)));
        draw_cross(img, x, l.y_spec + 2 * kLabel, l.cross_w, r.specular[k], scale);
        for (bool metal : {true, false}) {
            const int y = (metal ? l.y_metal : l.y_diel) + kLabel;
            draw_sphere(img, x, y, l.cell, scale, [&](const Vec3d& n, const Vec3d& v) {
                return shade_sphere(r, k, {n.x, n.y, n.z}, {v.x, v.y, v.z}, metal);
            });
        }
    }
    return img;
}

}  // namespace iblbake
