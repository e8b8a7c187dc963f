// Engine export: the presets table and its curves, mirrors and SH forms, the
// pixel formats, every container's bytes against its specification (KTX 2.0,
// Khronos Data Format, DDS, KTX 1.1 as Filament reads it, Babylon's .env), the
// plan that shares levels, and bakes whose preset levels are checked against
// the exhaustive reference at the preset's own roughness.
#include <gtest/gtest.h>
#include <Imath/half.h>
#include <nlohmann/json.hpp>
#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "iblbake/export/container.h"
#include "iblbake/export/convert.h"
#include "iblbake/export/export.h"
#include "iblbake/export/layout.h"
#include "iblbake/export/pixel.h"
#include "iblbake/export/preset.h"
#include "iblbake/ibl/cube_sampling.h"
#include "iblbake/io/image_io.h"
#include "iblbake/math/cube.h"
#include "iblbake/math/latlong.h"
#include "iblbake/pipeline/bake_file.h"
#include "iblbake/pipeline/exports.h"
#include "iblbake/pipeline/plan.h"
#include "reference.h"
#include "scratch.h"

using namespace iblbake;
namespace fs = std::filesystem;
using Bytes = std::vector<uint8_t>;

namespace {

fs::path temp_dir(const std::string& name) {
    return scratch::dir(name);
}

uint32_t u32(const Bytes& b, size_t at) {
    return uint32_t(b[at]) | uint32_t(b[at + 1]) << 8 | uint32_t(b[at + 2]) << 16 | uint32_t(b[at + 3]) << 24;
}
uint64_t u64(const Bytes& b, size_t at) { return uint64_t(u32(b, at)) | uint64_t(u32(b, at + 4)) << 32; }
uint16_t u16(const Bytes& b, size_t at) { return uint16_t(b[at] | b[at + 1] << 8); }
float f16(const Bytes& b, size_t at) {
    Imath::half h;
    h.setBits(u16(b, at));
    return float(h);
}
float f32(const Bytes& b, size_t at) {
    float v;
    std::memcpy(&v, b.data() + at, 4);
    return v;
}

Bytes read_file(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return Bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

// A cube whose texel (f, i, j) of level m holds (m + 1, f + 1, j n + i + 1):
// small integers, exact in every float format tested here.
Cubemap coded_cube(int n, int level) {
    Cubemap c(n);
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                float* p = c.at(f, i, j);
                p[0] = float(level + 1);
                p[1] = float(f + 1);
                p[2] = float(j * n + i + 1);
            }
    return c;
}

struct CodedChain {
    std::vector<Cubemap> cubes;
    CubeChain chain;
};
CodedChain coded_chain(int n0, int levels) {
    CodedChain c;
    for (int m = 0; m < levels; ++m) c.cubes.push_back(coded_cube(std::max(1, n0 >> m), m));
    for (const Cubemap& cube : c.cubes) c.chain.levels.push_back(&cube);
    return c;
}

const Preset& row(const std::string& name) {
    for (const Preset& p : preset_table())
        if (p.name == name) return p;
    throw std::logic_error("no preset " + name);
}

}  // namespace

// ---------------------------------------------------------------- presets

TEST(PresetCurves, EachIsTheInverseOfItsEnginesLod) {
    for (int levels : {2, 5, 6, 9}) {
        const int top = levels - 1;
        for (int m = 0; m < levels; ++m) {
            EXPECT_NEAR(lod_linear(roughness_linear(m, top), top), m, 1e-12);
            EXPECT_NEAR(lod_filament(roughness_filament(m, top), top), m, 1e-12);
        }
    }
    for (int m = 0; m <= 6; ++m) EXPECT_NEAR(lod_unity(roughness_unity(m)), m, 1e-12) << m;
    for (int m = 7; m < 12; ++m) EXPECT_EQ(roughness_unity(m), 1.0);
    for (int n0 : {64, 256, 1024})
        for (int m = 1; m < 20; ++m) {
            const double r = roughness_babylon(m, n0);
            if (r < 1.0) {
                EXPECT_NEAR(lod_babylon(r, n0), m, 1e-9) << n0 << " " << m;
            } else {
                EXPECT_LE(lod_babylon(1.0, n0), m + 1e-9);  // clamped past the lod of r = 1
            }
        }
    EXPECT_EQ(roughness_babylon(0, 256), 0.0);
    // Negative control: a chain on the linear curve read with Filament's lod
    // lands between levels.
    double worst = 0.0;
    for (int m = 0; m < 5; ++m) worst = std::max(worst, std::fabs(lod_filament(roughness_linear(m, 4), 4) - m));
    EXPECT_GT(worst, 0.5);
}

TEST(PresetCurves, MatchTheEnginesTable) {
    // ENGINES.md section 1 (N0 = 256; Filament M = 5).
    const double filament5[] = {0, .134, .293, .5, 1};
    const double unity[] = {0, .102, .215, .342, .492, .681, 1, 1, 1};
    const double babylon[] = {0, .096, .149, .229, .354, .545, .841, 1, 1};
    for (int m = 0; m < 5; ++m) EXPECT_NEAR(preset_roughness(row("three"), m, 5, 256), filament5[m], 5e-4);
    for (int m = 0; m < 5; ++m) EXPECT_NEAR(preset_roughness(row("filament"), m, 5, 256), filament5[m], 5e-4);
    for (int m = 0; m < 9; ++m) EXPECT_NEAR(preset_roughness(row("unity"), m, 9, 256), unity[m], 5e-4) << m;
    for (int m = 0; m < 9; ++m) EXPECT_NEAR(preset_roughness(row("babylon"), m, 9, 256), babylon[m], 5e-4) << m;
    for (int m = 0; m < 9; ++m) EXPECT_DOUBLE_EQ(preset_roughness(row("khronos"), m, 9, 256), m / 8.0);
}

TEST(Presets, LevelCounts) {
    EXPECT_EQ(preset_level_count(row("three"), 256), 5);     // 256 .. 16
    EXPECT_EQ(preset_level_count(row("filament"), 512), 6);  // 512 .. 16
    EXPECT_EQ(preset_level_count(row("khronos"), 256), 9);   // 256 .. 1
    EXPECT_EQ(preset_level_count(row("babylon"), 256), 9);
    EXPECT_EQ(preset_level_count(row("unity"), 128), 8);
    EXPECT_EQ(preset_level_count(row("khronos"), 100), 7);  // 100 50 25 12 6 3 1, as SPEC's chain
    EXPECT_EQ(preset_level_count(row("three"), 8), 1);      // smaller than its smallest: the base alone
}

TEST(Presets, ParseModifiersAndErrors) {
    EXPECT_EQ(parse_preset("khronos:rgba32f").format, PixelFormat::Rgba32f);
    EXPECT_FALSE(parse_preset("bevy:nozstd").zstd);
    EXPECT_TRUE(parse_preset("khronos:e5b9g9r9:zstd").zstd);
    EXPECT_EQ(parse_preset(" filament : r11g11b10f ").format, PixelFormat::R11g11b10f);
    auto message = [](const std::function<void()>& f) {
        try {
            f();
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_NE(message([] { parse_preset("unity:e5b9g9r9"); }).find("rgba16f, rgba32f"), std::string::npos);
    EXPECT_NE(message([] { parse_preset("unity:zstd"); }).find("KTX2 only"), std::string::npos);
    EXPECT_NE(message([] { parse_preset("threejs"); }).find("expected one of three, khronos"), std::string::npos);
    EXPECT_NE(message([] { parse_presets({"three,filament", "three"}); }).find("given twice"), std::string::npos);
    EXPECT_EQ(parse_presets({"three,filament", "babylon"}).size(), 3u);
    EXPECT_TRUE(parse_presets({}).empty());
    // Issue 24 (E14): contradictions and empty parts are refused, not the last one silently kept.
    EXPECT_NE(message([] { parse_preset("khronos:rgba32f:rgba16f"); }).find("contradict"), std::string::npos);
    EXPECT_NE(message([] { parse_preset("khronos:zstd:nozstd"); }).find("contradict"), std::string::npos);
    EXPECT_NE(message([] { parse_preset("khronos:"); }).find("empty modifier"), std::string::npos);
    EXPECT_NE(message([] { parse_presets({""}); }).find("empty preset"), std::string::npos);
    EXPECT_NE(message([] { parse_presets({"three,,khronos"}); }).find("empty preset name"), std::string::npos);
    // E6: a chain that would hold the mirror level alone.
    EXPECT_NE(message([] { check_preset_face_size(parse_preset("three"), 16); }).find("32 or more"), std::string::npos);
    EXPECT_EQ(message([] { check_preset_face_size(parse_preset("three"), 32); }), "");
    EXPECT_EQ(message([] { check_preset_face_size(parse_preset("khronos"), 2); }), "");
}

// ---------------------------------------------------------------- conventions

TEST(Mirror, RecipeMatchesTheMirroredDirection) {
    for (Mirror m : {Mirror::X, Mirror::Z})
        for (int n : {1, 2, 3, 4, 7}) {
            for (int f = 0; f < 6; ++f)
                for (int j = 0; j < n; ++j)
                    for (int i = 0; i < n; ++i) {
                        Vec3d d = texel_direction(f, i, j, n);
                        if (m == Mirror::X) d.x = -d.x;
                        else d.z = -d.z;
                        const FaceCoord fc = direction_to_face(d);
                        const TexelRef want{fc.face, std::min(n - 1, int(fc.s * n)), std::min(n - 1, int(fc.t * n))};
                        const TexelRef got = mirror_source(m, f, i, j, n);
                        ASSERT_EQ(got.face, want.face) << int(m) << " n " << n << " f " << f << " " << i << "," << j;
                        ASSERT_EQ(got.i, want.i);
                        ASSERT_EQ(got.j, want.j);
                        const TexelRef back = mirror_source(m, got.face, got.i, got.j, n);  // an involution
                        ASSERT_TRUE(back.face == f && back.i == i && back.j == j);
                    }
        }
    // Negative control: the x recipe is not the z mirror.
    const TexelRef wrong = mirror_source(Mirror::X, 4, 1, 2, 4);
    const TexelRef right = mirror_source(Mirror::Z, 4, 1, 2, 4);
    EXPECT_FALSE(wrong.face == right.face && wrong.i == right.i && wrong.j == right.j);
}

TEST(Mirror, RowsAndCubesFollowTheRecipe) {
    const Cubemap c = coded_cube(5, 0);
    for (Mirror m : {Mirror::None, Mirror::X, Mirror::Z}) {
        const Cubemap mc = mirror_cube(c, m);
        for (int f = 0; f < 6; ++f)
            for (int j = 0; j < 5; ++j) {
                const RowSource r = mirrored_row(c, m, f, j);
                for (int i = 0; i < 5; ++i) {
                    const TexelRef s = mirror_source(m, f, i, j, 5);
                    ASSERT_EQ(r.first + i * r.step, c.at(s.face, s.i, s.j));
                    ASSERT_EQ(std::memcmp(mc.at(f, i, j), c.at(s.face, s.i, s.j), 12), 0);
                }
            }
    }
}

TEST(Sh, MirrorFlipsAreTheMirroredRadiancesCoefficients) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1, 1);
    for (Mirror m : {Mirror::X, Mirror::Z})
        for (int trial = 0; trial < 50; ++trial) {
            Sh9 L;
            for (double& v : L) v = u(rng);
            const Vec3d d = normalize(Vec3d{u(rng), u(rng), u(rng)});
            const Vec3d md = m == Mirror::X ? Vec3d{-d.x, d.y, d.z} : Vec3d{d.x, d.y, -d.z};
            const Sh9 yd = sh9_basis(d), ymd = sh9_basis(md), ml = mirror_sh9(L, m);
            double mirrored = 0, flipped = 0, unflipped = 0;
            for (int i = 0; i < 9; ++i) {
                mirrored += L[i] * ymd[i];  // the radiance seen mirrored
                flipped += ml[i] * yd[i];
                unflipped += L[i] * yd[i];
            }
            ASSERT_NEAR(flipped, mirrored, 1e-12);
            if (trial == 0) {  // negative control
                EXPECT_GT(std::fabs(unflipped - mirrored), 1e-3);
            }
        }
}

TEST(Sh, FilamentScaleAndBabylonPolynomialEvaluateToIrradiance) {
    const double k[9] = {0.282095, 0.325735, 0.325735, 0.325735, 0.273137, 0.273137, 0.078848, 0.273137, 0.136569};
    for (int i = 0; i < 9; ++i) EXPECT_NEAR(kIrradianceShScale[i], k[i], 1e-6);  // ENGINES.md section 1
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1, 1);
    std::array<Sh9, 3> L{};
    for (auto& ch : L)
        for (double& v : ch) v = u(rng);
    const std::array<Sh9, 3> fil = filament_sh(L);
    const Polynomial poly = babylon_polynomial(L);
    for (int trial = 0; trial < 50; ++trial) {
        const Vec3d n = normalize(Vec3d{u(rng), u(rng), u(rng)});
        const double P[9] = {1, n.y, n.z, n.x, n.x * n.y, n.y * n.z, 3 * n.z * n.z - 1, n.x * n.z,
                             n.x * n.x - n.y * n.y};
        const std::array<double, 3> pv = evaluate(poly, n);
        for (int c = 0; c < 3; ++c) {
            const double want = sh9_irradiance(L[c], n);
            double f = 0, babylon = 0;
            for (int i = 0; i < 9; ++i) {
                f += fil[c][i] * P[i];
                // Babylon evaluates bands 1 and 2 3/2 and 4 times stronger: the
                // stored polynomial carries them times A_l / pi once more.
                babylon += kIrradianceShScale[i] * sh9_band_factor(i) * L[c][i] * P[i];
            }
            ASSERT_NEAR(f, want, 1e-9);
            ASSERT_NEAR(pv[c], babylon, 1e-9);
            if (trial == 0 && c == 0) {  // not the plain SH9 irradiance
                EXPECT_GT(std::fabs(pv[c] - want), 1e-4);
            }
        }
    }
}

// ---------------------------------------------------------------- pixel formats

TEST(Pixel, HalfIsIeeeRoundToNearestEven) {
    EXPECT_EQ(float_to_half(1.0f), 0x3C00);
    EXPECT_EQ(float_to_half(65504.0f), 0x7BFF);
    EXPECT_EQ(float_to_half(std::ldexp(1.0f, -24)), 0x0001);
    EXPECT_EQ(float_to_half(0.1f), 0x2E66);
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> e(-30, 16);
    for (int k = 0; k < 20000; ++k) {
        const float v = std::exp2(e(rng));
        ASSERT_EQ(float_to_half(v), Imath::half(v).bits()) << v;  // OpenEXR's half as the reference
    }
}

// The block conversion (F16C on this CPU, else software) against OpenEXR's
// half on every kind of value: ties, denormals, overflow, signs, Inf, NaN.
TEST(Pixel, BlockHalfConversionMatchesImath) {
    std::vector<float> v = {0.0f, -0.0f, 1.0f, -1.0f, 65504.0f, 65520.0f, 65519.0f, 1e6f, -1e6f,
                            std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                            std::ldexp(1.0f, -24), std::ldexp(1.0f, -25), std::ldexp(3.0f, -26), std::ldexp(1.0f, -30),
                            1.0f + std::ldexp(1.0f, -11), 1.0f + std::ldexp(3.0f, -11), 2049.0f, 2051.0f};
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> e(-30, 17);
    std::uniform_int_distribution<uint32_t> bits;
    for (int k = 0; k < 20000; ++k) v.push_back((k % 2 ? -1.0f : 1.0f) * std::exp2(e(rng)));
    for (int k = 0; k < 2000; ++k) {  // any bit pattern, NaNs excluded (their payloads may differ)
        const uint32_t b = bits(rng);
        float f;
        std::memcpy(&f, &b, 4);
        if (!std::isnan(f)) v.push_back(f);
    }
    std::vector<uint16_t> out(v.size() + 3);  // odd lengths take the scalar tail
    for (size_t n : {v.size(), size_t(7), size_t(1)}) {
        std::fill(out.begin(), out.end(), uint16_t(0xDEAD));
        floats_to_half(v.data(), out.data(), n);
        for (size_t k = 0; k < n; ++k) ASSERT_EQ(out[k], Imath::half(v[k]).bits()) << v[k];
        EXPECT_EQ(out[n], 0xDEAD);  // nothing past n written
    }
    const uint16_t nan = float_to_half(std::numeric_limits<float>::quiet_NaN());
    EXPECT_EQ(nan & 0x7C00, 0x7C00);
    EXPECT_NE(nan & 0x03FF, 0);
}

// Every binary16 pattern to float (F16C on this CPU, and the software path) against
// OpenEXR's half, into a buffer of its own and in place (the halves in the
// upper half of the floats' storage, as the EXR row reader puts them), at
// lengths that take the 8-wide loop and the scalar tail.
TEST(Pixel, HalvesToFloatsMatchesImathInPlaceToo) {
    auto same = [](float a, uint16_t h) {  // bit for bit, any NaN for a NaN
        Imath::half r;
        r.setBits(h);
        const float want = float(r);
        if (std::isnan(want)) return std::isnan(a);
        uint32_t x, y;
        std::memcpy(&x, &a, 4);
        std::memcpy(&y, &want, 4);
        return x == y;
    };
    std::vector<uint16_t> all(65536);
    for (size_t k = 0; k < all.size(); ++k) all[k] = uint16_t(k);
    for (auto convert : {&halves_to_floats, &detail::halves_to_floats_software}) {
        std::vector<float> out(all.size() + 1, -7.0f);
        convert(all.data(), out.data(), all.size());
        for (size_t k = 0; k < all.size(); ++k) ASSERT_TRUE(same(out[k], all[k])) << k;
        EXPECT_EQ(out[all.size()], -7.0f);  // nothing past n written
        for (size_t n : {size_t(65536), size_t(13), size_t(8), size_t(1)}) {
            std::vector<float> buf(n + 1, -7.0f);
            std::memcpy(reinterpret_cast<char*>(buf.data()) + 2 * n, all.data() + (65536 - n), 2 * n);
            convert(reinterpret_cast<char*>(buf.data()) + 2 * n, buf.data(), n);
            for (size_t k = 0; k < n; ++k) ASSERT_TRUE(same(buf[k], all[65536 - n + k])) << n << " " << k;
            EXPECT_EQ(buf[n], -7.0f);
        }
    }
}

TEST(Pixel, E5B9G9R9FollowsTheSharedExponentSpec) {
    // (1, 1, 1): exponent 16 (bias 15, 9 mantissa bits), mantissas 256.
    EXPECT_EQ(pack_e5b9g9r9(1, 1, 1), 256u | 256u << 9 | 256u << 18 | 16u << 27);
    EXPECT_EQ(pack_e5b9g9r9(0, 0, 0), 0u);
    float out[3];
    std::mt19937 rng(2);
    std::uniform_real_distribution<float> e(-12, 15.9f), u(0, 1);
    for (int k = 0; k < 20000; ++k) {
        const float m = std::exp2(e(rng)), v[3] = {m, m * u(rng), m * u(rng) * u(rng)};
        unpack_e5b9g9r9(pack_e5b9g9r9(v[0], v[1], v[2]), out);
        for (int c = 0; c < 3; ++c) ASSERT_LE(std::fabs(out[c] - v[c]), m * std::ldexp(1.0f, -9) * 1.0001f) << m;
    }
    unpack_e5b9g9r9(pack_e5b9g9r9(1e6f, 1, 0), out);
    EXPECT_EQ(out[0], 65408.0f);  // clamped to the largest value
}

TEST(Pixel, R11G11B10FollowsThePackedFloatSpec) {
    EXPECT_EQ(pack_r11g11b10f(1, 0, 0), 15u << 6);
    EXPECT_EQ(pack_r11g11b10f(0, 0, 1), (15u << 5) << 22);
    float out[3];
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> e(-14, 15.9f);
    for (int k = 0; k < 20000; ++k) {
        const float v[3] = {std::exp2(e(rng)), std::exp2(e(rng)), std::exp2(e(rng))};
        unpack_r11g11b10f(pack_r11g11b10f(v[0], v[1], v[2]), out);
        for (int c = 0; c < 3; ++c) ASSERT_LE(std::fabs(out[c] - v[c]), v[c] * std::ldexp(1.0f, c < 2 ? -7 : -6) * 1.001f);
    }
    unpack_r11g11b10f(pack_r11g11b10f(1e9f, 1e9f, 1e9f), out);
    EXPECT_EQ(out[0], 65024.0f);
    EXPECT_EQ(out[2], 64512.0f);
}

TEST(Pixel, ValuesBeyondAFormatAreClampedAndCounted) {
    const float rgb[6] = {1e5f, 1, 1, 2, 2, 2};
    uint8_t out[16];
    PackStats s;
    pack_texels(rgb, 2, PixelFormat::Rgba16f, out, s);
    EXPECT_EQ(s.clamped, 1u);
    EXPECT_EQ(s.largest, 1e5f);
    EXPECT_EQ(out[0] | out[1] << 8, 0x7BFF);  // 65504, not infinity
    EXPECT_EQ(out[6] | out[7] << 8, 0x3C00);  // alpha 1
}

// ---------------------------------------------------------------- containers

TEST(Ktx2, HeaderIndexDfdKeyValuesAndDataFollowTheSpec) {
    const CodedChain c = coded_chain(4, 3);
    EncodeOptions o;
    o.writer = "iblbake test";
    const Bytes b = encode_ktx2(c.chain, o).bytes;
    const uint8_t id[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
    ASSERT_EQ(std::memcmp(b.data(), id, 12), 0);
    EXPECT_EQ(u32(b, 12), 97u);  // VK_FORMAT_R16G16B16A16_SFLOAT
    EXPECT_EQ(u32(b, 16), 2u);   // typeSize
    EXPECT_EQ(u32(b, 20), 4u);
    EXPECT_EQ(u32(b, 24), 4u);
    EXPECT_EQ(u32(b, 28), 0u);  // pixelDepth
    EXPECT_EQ(u32(b, 32), 0u);  // layerCount
    EXPECT_EQ(u32(b, 36), 6u);  // faceCount
    EXPECT_EQ(u32(b, 40), 3u);  // levelCount
    EXPECT_EQ(u32(b, 44), 0u);  // no supercompression
    const uint32_t dfd_at = u32(b, 48), dfd_len = u32(b, 52), kvd_at = u32(b, 56), kvd_len = u32(b, 60);
    EXPECT_EQ(dfd_at, 80u + 3 * 24);
    EXPECT_EQ(dfd_len, 92u);
    EXPECT_EQ(kvd_at, dfd_at + dfd_len);
    EXPECT_EQ(u64(b, 64), 0u);
    EXPECT_EQ(u64(b, 72), 0u);
    // Basic DFD, word by word (Khronos Data Format 1.3; KTX-Software's createDFDUnpacked).
    const uint32_t want[] = {92, 0, 2u | 88u << 16, 1u | 1u << 8 | 1u << 16, 0, 8, 0,
                             0u | 15u << 16 | 0xC0u << 24, 0, 0xBF800000u, 0x3F800000u,
                             16u | 15u << 16 | 0xC1u << 24, 0, 0xBF800000u, 0x3F800000u,
                             32u | 15u << 16 | 0xC2u << 24, 0, 0xBF800000u, 0x3F800000u,
                             48u | 15u << 16 | 0xCFu << 24, 0, 0xBF800000u, 0x3F800000u};
    for (size_t k = 0; k < sizeof(want) / 4; ++k) EXPECT_EQ(u32(b, dfd_at + 4 * k), want[k]) << "DFD word " << k;
    // Key/value data sorted by key, each entry padded to 4 bytes.
    std::vector<std::pair<std::string, std::string>> kv;
    for (size_t at = kvd_at; at < kvd_at + kvd_len;) {
        const uint32_t len = u32(b, at);
        const std::string entry(reinterpret_cast<const char*>(b.data() + at + 4), len);
        const size_t nul = entry.find('\0');
        kv.emplace_back(entry.substr(0, nul), entry.substr(nul + 1));
        at += 4 + (len + 3) / 4 * 4;
    }
    ASSERT_EQ(kv.size(), 2u);
    EXPECT_EQ(kv[0].first, "KTXorientation");
    EXPECT_EQ(kv[0].second, std::string("rd") + '\0');
    EXPECT_EQ(kv[1].first, "KTXwriter");
    EXPECT_EQ(kv[1].second, std::string("iblbake test") + '\0');
    // Level index: level 0 first; data smallest level first, aligned to 8.
    uint64_t offset[3], length[3];
    for (int m = 0; m < 3; ++m) {
        offset[m] = u64(b, 80 + 24 * m);
        length[m] = u64(b, 80 + 24 * m + 8);
        EXPECT_EQ(u64(b, 80 + 24 * m + 16), length[m]);
        const uint64_t n = std::max(1, 4 >> m);
        EXPECT_EQ(length[m], 6 * n * n * 8);
        EXPECT_EQ(offset[m] % 8, 0u);
    }
    EXPECT_LT(offset[2], offset[1]);
    EXPECT_LT(offset[1], offset[0]);
    EXPECT_EQ(offset[2], (kvd_at + kvd_len + 7) / 8 * 8);
    EXPECT_EQ(offset[0] + length[0], b.size());
    // Texels: faces +X..-Z, rows top to bottom, RGBA with alpha 1.
    for (int m = 0; m < 3; ++m) {
        const int n = std::max(1, 4 >> m);
        for (int f = 0; f < 6; ++f)
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i) {
                    const size_t at = offset[m] + ((size_t(f) * n + j) * n + i) * 8;
                    ASSERT_EQ(f16(b, at), float(m + 1));
                    ASSERT_EQ(f16(b, at + 2), float(f + 1));
                    ASSERT_EQ(f16(b, at + 4), float(j * n + i + 1));
                    ASSERT_EQ(f16(b, at + 6), 1.0f);
                }
    }
}

TEST(Ktx2, E5B9G9R9WithZstdAndRgba32f) {
    const CodedChain c = coded_chain(8, 4);
    EncodeOptions o;
    o.format = PixelFormat::E5b9g9r9;
    o.zstd = true;
    const Bytes b = encode_ktx2(c.chain, o).bytes;
    EXPECT_EQ(u32(b, 12), 123u);  // VK_FORMAT_E5B9G9R9_UFLOAT_PACK32
    EXPECT_EQ(u32(b, 16), 4u);
    EXPECT_EQ(u32(b, 44), 2u);  // Zstandard
    const uint32_t dfd_at = u32(b, 48);
    // KTX-Software's E5B9G9R9 DFD: 6 samples, mantissas (9 bits, upper 8448)
    // and the shared exponent (5 bits at 27, bounds 15 and 31) per channel.
    EXPECT_EQ(u32(b, dfd_at), 4u + 24 + 6 * 16);
    EXPECT_EQ(u32(b, dfd_at + 20), 4u);  // bytesPlane0
    for (uint32_t ch = 0; ch < 3; ++ch) {
        const size_t s = dfd_at + 28 + 32 * ch;
        EXPECT_EQ(u32(b, s), (9 * ch) | 8u << 16 | ch << 24);
        EXPECT_EQ(u32(b, s + 8), 0u);
        EXPECT_EQ(u32(b, s + 12), 8448u);
        EXPECT_EQ(u32(b, s + 16), 27u | 4u << 16 | (0x20u | ch) << 24);
        EXPECT_EQ(u32(b, s + 24), 15u);
        EXPECT_EQ(u32(b, s + 28), 31u);
    }
    // Supercompressed levels: no alignment; each decompresses (libzstd) to its texels.
    uint64_t end = 0;
    for (int m = 3; m >= 0; --m) {
        const uint64_t at = u64(b, 80 + 24 * m), len = u64(b, 88 + 24 * m), raw = u64(b, 96 + 24 * m);
        if (m < 3) {  // packed back to back, smallest first
            EXPECT_EQ(at, end);
        }
        end = at + len;
        const int n = std::max(1, 8 >> m);
        ASSERT_EQ(raw, uint64_t(6 * n * n * 4));
        Bytes out(raw);
        ASSERT_EQ(ZSTD_decompress(out.data(), out.size(), b.data() + at, len), raw);
        for (int f = 0; f < 6; ++f)
            for (int t = 0; t < n * n; ++t) {
                float v[3];
                unpack_e5b9g9r9(u32(out, (size_t(f) * n * n + t) * 4), v);
                const float want[3] = {float(m + 1), float(f + 1), float(t + 1)};
                const float tol = std::max({want[0], want[1], want[2]}) * std::ldexp(1.0f, -9);  // the shared exponent
                for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(v[ch], want[ch], tol);
            }
    }
    EXPECT_EQ(end, b.size());

    o.format = PixelFormat::Rgba32f;
    o.zstd = false;
    const Bytes f = encode_ktx2(c.chain, o).bytes;
    EXPECT_EQ(u32(f, 12), 109u);
    for (int m = 0; m < 4; ++m) EXPECT_EQ(u64(f, 80 + 24 * m) % 16, 0u);  // lcm(16, 4)
    EXPECT_EQ(f32(f, u64(f, 80) + 4 * 4 * 5 + 8), 6.0f);  // level 0, +X, texel 5: blue 6
}

TEST(Dds, HeaderAndFaceMajorData) {
    const CodedChain c = coded_chain(4, 3);
    EncodeOptions o;
    const Bytes b = encode_dds(c.chain, o).bytes;
    ASSERT_EQ(std::memcmp(b.data(), "DDS ", 4), 0);
    EXPECT_EQ(u32(b, 4), 124u);
    EXPECT_EQ(u32(b, 8), 0x1u | 0x2 | 0x4 | 0x8 | 0x1000 | 0x20000);
    EXPECT_EQ(u32(b, 12), 4u);
    EXPECT_EQ(u32(b, 16), 4u);
    EXPECT_EQ(u32(b, 20), 4u * 8);  // pitch
    EXPECT_EQ(u32(b, 28), 3u);      // mip count
    EXPECT_EQ(u32(b, 76), 32u);
    EXPECT_EQ(u32(b, 80), 0x4u);  // DDPF_FOURCC
    EXPECT_EQ(std::memcmp(b.data() + 84, "DX10", 4), 0);
    EXPECT_EQ(u32(b, 108), 0x8u | 0x1000 | 0x400000);
    EXPECT_EQ(u32(b, 112), 0x200u | 0xFC00);
    EXPECT_EQ(u32(b, 128), 10u);  // DXGI_FORMAT_R16G16B16A16_FLOAT
    EXPECT_EQ(u32(b, 132), 3u);   // TEXTURE2D
    EXPECT_EQ(u32(b, 136), 4u);   // TEXTURECUBE
    EXPECT_EQ(u32(b, 140), 1u);
    size_t at = 148;
    for (int f = 0; f < 6; ++f)
        for (int m = 0; m < 3; ++m) {
            const int n = std::max(1, 4 >> m);
            for (int t = 0; t < n * n; ++t, at += 8) {
                ASSERT_EQ(f16(b, at), float(m + 1)) << f << " " << m;
                ASSERT_EQ(f16(b, at + 2), float(f + 1));
                ASSERT_EQ(f16(b, at + 4), float(t + 1));
            }
        }
    EXPECT_EQ(at, b.size());
    o.format = PixelFormat::Rgba32f;
    EXPECT_EQ(u32(encode_dds(c.chain, o).bytes, 128), 2u);
    o.format = PixelFormat::E5b9g9r9;
    EXPECT_THROW(encode_dds(c.chain, o), std::invalid_argument);
}

TEST(Ktx1, HeaderShKeyAndLevelsAsFilamentReadsThem) {
    const CodedChain c = coded_chain(4, 3);
    EncodeOptions o;
    std::string sh;
    for (int k = 0; k < 27; ++k) sh += std::to_string(0.5 * k - 3) + (k % 3 == 2 ? "\n" : " ");
    o.key_values.emplace_back("sh", sh);
    const Bytes b = encode_ktx1(c.chain, o).bytes;
    const uint8_t id[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x31, 0x31, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
    ASSERT_EQ(std::memcmp(b.data(), id, 12), 0);
    const uint32_t want[13] = {0x04030201, 0x140B, 2, 0x1908, 0x881A, 0x1908, 4, 4, 0, 0, 6, 3, 0};
    for (int k = 0; k < 12; ++k) EXPECT_EQ(u32(b, 12 + 4 * k), want[k]) << "header word " << k;
    const uint32_t kv_len = u32(b, 60);
    // One entry: "sh\0" + value, padded to 4 (Ktx1Bundle's valuePadding).
    const uint32_t len = u32(b, 64);
    EXPECT_EQ(len, 3 + sh.size());
    EXPECT_EQ(kv_len, 4 + (len + 3) / 4 * 4);
    const std::string value(reinterpret_cast<const char*>(b.data() + 68 + 3), sh.size());
    std::istringstream in(value);
    for (int k = 0; k < 27; ++k) {
        float v = 0;
        ASSERT_TRUE(in >> v);
        ASSERT_FLOAT_EQ(v, float(0.5 * k - 3));
    }
    size_t at = 64 + kv_len;
    for (int m = 0; m < 3; ++m) {
        const int n = std::max(1, 4 >> m);
        EXPECT_EQ(u32(b, at), uint32_t(n * n * 8));  // imageSize: one face
        at += 4;
        for (int f = 0; f < 6; ++f)
            for (int t = 0; t < n * n; ++t, at += 8) {
                ASSERT_EQ(f16(b, at), float(m + 1));
                ASSERT_EQ(f16(b, at + 2), float(f + 1));
                ASSERT_EQ(f16(b, at + 4), float(t + 1));
            }
    }
    EXPECT_EQ(at, b.size());
    o.format = PixelFormat::R11g11b10f;
    const Bytes r = encode_ktx1(c.chain, o).bytes;
    EXPECT_EQ(u32(r, 16), 0x8C3Au);  // glType as Filament's Ktx1Reader expects it
    EXPECT_EQ(u32(r, 24), 0x1907u);  // RGB
    EXPECT_EQ(u32(r, 28), 0x8C3Au);
}

TEST(Env, HeaderPositionsAndImagesAsBabylonReadsThem) {
    const CodedChain c = coded_chain(4, 3);
    EncodeOptions o;
    o.polynomial = babylon_polynomial(std::array<Sh9, 3>{});
    o.polynomial->x = {1.5, 2.5, 3.5};
    const Bytes b = encode_env(c.chain, o).bytes;
    const uint8_t magic[8] = {0x86, 0x16, 0x87, 0x96, 0xF6, 0xD6, 0x96, 0x36};
    ASSERT_EQ(std::memcmp(b.data(), magic, 8), 0);
    const size_t nul = std::find(b.begin() + 8, b.end(), 0) - b.begin();
    ASSERT_LT(nul, b.size());
    const nlohmann::json info = nlohmann::json::parse(std::string(b.begin() + 8, b.begin() + nul));
    for (unsigned char ch : std::string(b.begin() + 8, b.begin() + nul)) ASSERT_LT(ch, 128);  // ASCII
    EXPECT_EQ(info["version"], 2);
    EXPECT_EQ(info["width"], 4);
    EXPECT_EQ(info["imageType"], "image/png");
    EXPECT_EQ(info["specular"]["lodGenerationScale"], 0.8);
    EXPECT_EQ(info["irradiance"]["x"][2], 3.5);
    for (const char* k : {"x", "y", "z", "xx", "yy", "zz", "yz", "zx", "xy"}) EXPECT_EQ(info["irradiance"][k].size(), 3u);
    const auto& mips = info["specular"]["mipmaps"];
    ASSERT_EQ(mips.size(), 6u * 3);  // 6 (log2(4) + 1), level-major
    size_t pos = 0;
    for (size_t k = 0; k < mips.size(); ++k) {
        EXPECT_EQ(mips[k]["position"], pos);  // counted from the byte after the NUL
        const size_t at = nul + 1 + pos, len = mips[k]["length"];
        const uint8_t png[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
        ASSERT_EQ(std::memcmp(b.data() + at, png, 8), 0);
        const int n = std::max(1, 4 >> (k / 6));
        EXPECT_EQ(b[at + 16] << 24 | b[at + 17] << 16 | b[at + 18] << 8 | b[at + 19], n);  // IHDR width
        EXPECT_EQ(b[at + 24], 8);  // bit depth
        EXPECT_EQ(b[at + 25], 6);  // RGBA
        pos += len;
    }
    EXPECT_EQ(nul + 1 + pos, b.size());
    // Babylon refuses anything but the full chain of a power-of-two face.
    CodedChain short_chain = coded_chain(4, 2);
    EXPECT_THROW(encode_env(short_chain.chain, o), std::invalid_argument);
    CodedChain odd = coded_chain(6, 3);
    EXPECT_THROW(encode_env(odd.chain, o), std::invalid_argument);
}

TEST(Rgbd, RoundTripsAndRoundsTheGammaExactly) {
    float worst = 0.0f;
    for (double e = -12; e < 8; e += 0.01) {
        const float v = float(std::exp2(e)), rgb[3] = {v, v * 0.5f, v * 0.25f};
        uint8_t q[4];
        rgbd_encode(rgb, q);
        ASSERT_GE(q[3], 1);
        float back[3];
        rgbd_decode(q, back);
        // Above 1 the largest channel is scaled into [1/2, 1] before its gamma
        // byte: relative precision. Below 1 D is 1 and RGBD is plain 8-bit
        // gamma: half a step in gamma space.
        if (v >= 1.0f) worst = std::max(worst, std::fabs(back[0] - v) / v);
        else ASSERT_LE(std::fabs(std::pow(back[0], 1 / 2.2f) - std::pow(v, 1 / 2.2f)), 0.5f / 255 + 1e-5f) << v;
        // The gamma byte is round(255 (v D)^(1/2.2)), computed here in double.
        const double d = q[3] / 255.0;
        for (int c = 0; c < 3; ++c) {
            const double want = std::round(255.0 * std::pow(std::min(1.0, double(rgb[c]) * d), 1.0 / 2.2));
            ASSERT_LE(std::fabs(q[c] - want), 1.0) << v;  // float D and a value on a rounding edge
        }
    }
    EXPECT_LT(worst, 0.02f);  // the largest channel keeps 8-bit gamma precision
    const float big[3] = {1000, 1, 1};
    uint8_t q[4];
    rgbd_encode(big, q);
    EXPECT_EQ(q[0], 255);  // beyond RGBD's 255: clamped
    EXPECT_EQ(q[3], 1);
}

TEST(Containers, RefuseChainsThatAreNotMipChains) {
    CodedChain c = coded_chain(4, 3);
    EncodeOptions o;
    std::swap(c.chain.levels[1], c.chain.levels[2]);
    EXPECT_THROW(encode_ktx2(c.chain, o), std::invalid_argument);
    EXPECT_THROW(encode_ktx2(CubeChain{}, o), std::invalid_argument);
}

// ---------------------------------------------------------------- plan and bake

TEST(Plan, SixPresetsShareTheirLevels) {
    BakeOptions bo;  // face 256, SPEC's 9 levels, karis LUT
    const auto plans = plan_presets(bo, parse_presets({"khronos,bevy,three,filament,babylon,unity"}));
    const ExtraOutputs x = extra_outputs(bo, plans);
    // khronos and bevy use SPEC's chain; three and filament the same 4 levels;
    // babylon 7 of its own (its 1 x 1 is SPEC's); unity 6 (its 2 x 2 at r = 1 is babylon's).
    EXPECT_EQ(x.specular.size(), 4u + 7 + 6);
    for (size_t i = 0; i < x.specular.size(); ++i)
        for (size_t k = 0; k < i; ++k)
            EXPECT_FALSE(x.specular[i].face_size == x.specular[k].face_size &&
                         same_roughness(x.specular[i].roughness, x.specular[k].roughness));
    EXPECT_FALSE(x.irradiance);  // SPEC's irradiance serves khronos and bevy
    ASSERT_EQ(x.luts.size(), 1u);
    EXPECT_EQ(x.luts[0], LutModel::HeightCorrelated);
    EXPECT_FALSE(x.keep_source);
    // Without SPEC's specular or irradiance, the presets still get theirs.
    bo.specular = bo.irradiance = false;
    const ExtraOutputs y = extra_outputs(bo, plans);
    EXPECT_EQ(y.specular.size(), 9u + 4 + 7 + 6);
    EXPECT_TRUE(y.irradiance);
    BakeOptions odd;
    odd.face_size = 96;
    EXPECT_THROW(plan_presets(odd, parse_presets({"babylon"})), std::invalid_argument);
}

TEST(Export, PresetLevelsAreIntegratedAtTheirOwnRoughness) {
    // A sun on a dim sky: neighbouring roughness values give clearly different levels.
    const Image src = ref::sun_source(256, 128, normalize(Vec3d{0.3, -0.5, 0.6}), 3.0, 500.0f, 0.2f);
    BakeOptions bo;
    bo.face_size = 32;
    bo.irradiance_size = 8;
    bo.lut = false;
    WriteOptions wo;
    wo.presets = parse_presets({"babylon,unity,three"});
    const BakePlan plan = make_plan(bo, wo);
    const BakeResult r = compute_bake(src, plan.bake);
    const ref::TexelTable table = ref::texel_table(src);
    for (const PresetPlan& preset : plan.presets)
        for (const PresetLevel& l : preset.levels) {
            if (l.roughness == 0.0 || l.face_size < 4) continue;
            const Cubemap& cube = baked_level(r, l.face_size, l.roughness);
            // The SPEC roughness nearest to this level's, as a resampling would use.
            const double spec_r = std::round(l.roughness * 5) / 5.0;
            double err = 0, err_wrong = 0;
            int count = 0;
            for (const ref::CubeTexel& t : ref::sample_texels(l.face_size, 40, 11)) {
                const Vec3d n = texel_direction(t.f, t.i, t.j, l.face_size);
                const ref::Rgb want = ref::prefiltered(table, n, l.roughness);
                const ref::Rgb wrong = ref::prefiltered(table, n, spec_r);
                const float* got = cube.at(t.f, t.i, t.j);
                const double w = want[0] + want[1] + want[2], g = got[0] + got[1] + got[2];
                err += std::fabs(g - w) / w;
                err_wrong += std::fabs((wrong[0] + wrong[1] + wrong[2]) - w) / w;
                ++count;
            }
            err /= count;
            err_wrong /= count;
            EXPECT_LT(err, 0.01) << preset.preset.name << " level " << l.level << " r " << l.roughness;
            // Negative control: the nearest SPEC roughness would be clearly off.
            if (std::fabs(spec_r - l.roughness) > 0.03) {
                EXPECT_GT(err_wrong, 3 * err) << preset.preset.name << " " << l.level;
            }
        }
}

TEST(Export, SixPresetBakeWritesEveryFileAndTheManifestSaysWhat) {
    const fs::path dir = temp_dir("six");
    const fs::path src = dir / "src.exr";
    io::write_exr(src.string(), ref::random_smooth_source(128, 64, 5), io::ExrPixel::Float);
    BakeOptions bo;
    bo.face_size = 32;
    bo.irradiance_size = 8;
    bo.lut_size = 32;
    WriteOptions wo;
    wo.presets = parse_presets({"khronos", "bevy", "three", "filament", "babylon", "unity", "source"});
    const nlohmann::json m = bake_file(src.string(), dir / "out", make_plan(bo, wo));
    ASSERT_TRUE(m.contains("presets"));
    for (const Preset& p : wo.presets) {
        const auto& e = m["presets"][p.name];
        EXPECT_EQ(e["dir"], p.name);
        EXPECT_EQ(e["mirror"], mirror_name(p.mirror));
        ASSERT_FALSE(e["files"].empty()) << p.name;
        for (const auto& [role, file] : e["files"].items())
            EXPECT_TRUE(fs::is_regular_file(dir / "out" / p.name / file.get<std::string>())) << p.name << " " << role;
        if (p.container != Container::Source) {
            const auto& levels = e["specular"];
            ASSERT_EQ(int(levels.size()), preset_level_count(p, 32));
            for (size_t k = 0; k < levels.size(); ++k)
                EXPECT_NEAR(levels[k]["roughness"].get<double>(), preset_roughness(p, int(k), int(levels.size()), 32),
                            1e-12);
            EXPECT_FALSE(e["lod_formula"].get<std::string>().empty());
        }
    }
    EXPECT_EQ(m["presets"]["filament"]["sh"]["coefficients"].size(), 27u);
    EXPECT_EQ(m["presets"]["three"]["sh"]["coefficients"][0], m["sh9"][0][0]);  // unmirrored sh9
    EXPECT_TRUE(m["presets"]["bevy"]["sh"].is_null());
    EXPECT_EQ(m["presets"]["khronos"]["lut"]["model"], "height-correlated");
    // The source preset keeps the cleaned source (EXR as read back, HDR within RGBE).
    const Image back = io::read_image((dir / "out" / "source" / "source.exr").string()).image;
    EXPECT_EQ(back.width, 128);
    const Image hdr = io::read_image((dir / "out" / "source" / "source.hdr").string()).image;  // OpenImageIO's reader
    const Image orig = ref::random_smooth_source(128, 64, 5);
    for (size_t k = 0; k < orig.pixels.size(); k += 97) {
        EXPECT_EQ(back.pixels[k], orig.pixels[k]);
        const float* px = &orig.pixels[k - k % 3];
        const float largest = std::max({px[0], px[1], px[2]});
        EXPECT_NEAR(hdr.pixels[k], orig.pixels[k], largest / 128 + 1e-6);  // RGBE: 8 bits under a shared exponent
    }
    fs::remove_all(dir);
}

TEST(Export, MarkerColoursLandWhereEachMirrorPutsThem) {
    // Six regions: the colour of the nearest axis (engine space) at every texel.
    const float colour[6][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 0}, {1, 0, 1}, {0, 1, 1}};
    Image src(256, 128);
    for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 256; ++x) {
            const Vec3d d = blender_to_engine(latlong_texel_direction(x, y, 256, 128));
            const double a[3] = {std::fabs(d.x), std::fabs(d.y), std::fabs(d.z)};
            const int axis = a[0] >= a[1] && a[0] >= a[2] ? 0 : a[1] >= a[2] ? 1 : 2;
            const int face = 2 * axis + ((axis == 0 ? d.x : axis == 1 ? d.y : d.z) < 0);
            std::copy_n(colour[face], 3, src.at(x, y));
        }
    const fs::path dir = temp_dir("marker");
    io::write_exr((dir / "src.exr").string(), src, io::ExrPixel::Float);
    BakeOptions bo;
    bo.face_size = 32;  // three needs two levels at least (issue 24, E6)
    bo.irradiance_size = 4;
    bo.lut = false;
    WriteOptions wo;
    wo.presets = parse_presets({"khronos", "three", "bevy:rgba16f:nozstd"});  // bevy's mirror, read as RGBA16F
    bake_file((dir / "src.exr").string(), dir / "out", make_plan(bo, wo));
    // The centre texel of each face of level 0 in each KTX2 file.
    auto centre = [&](const std::string& preset, int face, float out[3]) {
        const Bytes b = read_file(dir / "out" / preset / "specular.ktx2");
        const size_t n = 32, at = u64(b, 80) + ((face * n + n / 2) * n + n / 2) * 8;
        for (int c = 0; c < 3; ++c) out[c] = f16(b, at + 2 * c);
    };
    // none: the face's own colour; x: +X and -X swapped; z: +Z and -Z swapped.
    const int expect[3][6] = {{0, 1, 2, 3, 4, 5}, {1, 0, 2, 3, 4, 5}, {0, 1, 2, 3, 5, 4}};
    const char* names[3] = {"khronos", "three", "bevy"};
    for (int p = 0; p < 3; ++p)
        for (int f = 0; f < 6; ++f) {
            float v[3];
            centre(names[p], f, v);
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(v[c], colour[expect[p][f]][c], 1e-3) << names[p] << " face " << f;
        }
    fs::remove_all(dir);
}

TEST(Layout, VerticalCrossFacesAndLatLong) {
    const Cubemap c = coded_cube(4, 0);
    std::vector<float> v(size_t(12) * 16 * 4);
    vcross_rgba_rows(c, 0, 16, v.data());
    auto at = [&](int x, int y) { return &v[(size_t(y) * 12 + x) * 4]; };
    // +Y at (1, 0), -X (0, 1), +Z (1, 1), +X (2, 1), -Y (1, 2), -Z (1, 3) turned 180 degrees.
    const int cells[6][2] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {1, 3}};
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
                const float* s = f == 5 ? c.at(f, 3 - i, 3 - j) : c.at(f, i, j);
                const float* d = at(cells[f][0] * 4 + i, cells[f][1] * 4 + j);
                ASSERT_EQ(d[0], s[0]);
                ASSERT_EQ(d[1], s[1]);
                ASSERT_EQ(d[2], s[2]);
                ASSERT_EQ(d[3], 1.0f);
            }
    EXPECT_EQ(at(0, 0)[3], 0.0f);  // unused cells transparent
    // -Z turned: its top row joins -Y's bottom row (both hold the directions at y = -1, z -> -1).
    const Vec3d ny_bottom = texel_direction(3, 1, 3, 4), nz_top = texel_direction(5, 2, 3, 4);
    EXPECT_GT(dot(ny_bottom, nz_top), 0.9);
    // Lat-long: each texel the bilinear cube lookup at its direction.
    Cubemap smooth(8);
    for (int f = 0; f < 6; ++f)
        for (int j = 0; j < 8; ++j)
            for (int i = 0; i < 8; ++i) {
                const Vec3d d = texel_direction(f, i, j, 8);
                float* p = smooth.at(f, i, j);
                p[0] = float(2 + d.x);
                p[1] = float(2 + d.y);
                p[2] = float(2 + d.z);
            }
    const BorderedCube b = BorderedCube::from_cube(smooth);
    std::vector<float> ll(size_t(32) * 16 * 4);
    latlong_rgba_rows(b, 32, 16, 0, 16, ll.data());
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 32; ++x) {
            const Vec3d d = blender_to_engine(latlong_texel_direction(x, y, 32, 16));
            const float* p = &ll[(size_t(y) * 32 + x) * 4];
            ASSERT_NEAR(p[0], 2 + d.x, 0.03);  // a linear function, up to the cube's bilinear error
            ASSERT_NEAR(p[1], 2 + d.y, 0.03);
            ASSERT_NEAR(p[2], 2 + d.z, 0.03);
        }
    EXPECT_THROW(layout_from_name("cross"), std::invalid_argument);
}
