#include "iblbake/export/export.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <stdexcept>

#include "iblbake/export/container.h"
#include "iblbake/export/convert.h"
#include "iblbake/export/sun.h"
#include "iblbake/io/image_io.h"

namespace iblbake {

using nlohmann::json;
namespace fs = std::filesystem;

std::vector<double> sh_coefficients(const std::array<Sh9, 3>& sh) {
    std::vector<double> out;
    for (int i = 0; i < 9; ++i)
        for (int c = 0; c < 3; ++c) out.push_back(sh[c][i]);
    return out;
}

namespace {

std::string sh_text(const std::array<Sh9, 3>& sh) {
    std::string s;
    char buf[64];
    for (int i = 0; i < 9; ++i) {
        std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g\n", sh[0][i], sh[1][i], sh[2][i]);
        s += buf;
    }
    return s;
}

std::string sh_form_text(const Preset& p) {
    switch (p.sh) {
        case ShForm::Raw:
            return "sh9: the radiance's SH9 (SPEC section 5), three.js SphericalHarmonics3 order and constants, "
                   "coefficient by coefficient (r g b)" +
                   std::string(p.sh_mirrored ? ", mirrored" : ", not mirrored (evaluated at the world normal)");
        case ShForm::Filament:
            return "filament: pre-scaled irradiance SH, sh9 x k (k = A_l c_lm / pi), as the KTX1 `sh` key and "
                   "IndirectLight::Builder::irradiance(3, sh)";
        case ShForm::BabylonPolynomial:
            return "babylon-polynomial: SphericalPolynomial x, y, z, xx, yy, zz, yz, zx, xy (r g b each), "
                   "evaluating to Irr, from the mirrored sh9";
        case ShForm::None: break;
    }
    return "";
}

json file_entry(const std::string& name, const Encoded& e) {
    return {{"file", name}, {"bytes", e.bytes.size()}, {"clamped_texels", e.stats.clamped},
            {"largest_value", e.stats.largest}};
}

std::string lod_text(const Preset& p, int levels, int n0) {
    std::string s = p.lod_formula;
    if (p.curve == RoughnessCurve::Linear || p.curve == RoughnessCurve::Filament)
        s += "; here T = " + std::to_string(levels - 1);
    if (p.curve == RoughnessCurve::Babylon) s += "; here N0 = " + std::to_string(n0);
    return s;
}

json run_preset(const ExportInput& in, const fs::path& root, const std::string& writer, const LutFileMaker& lut_file) {
    const Preset& p = in.preset;
    const fs::path dir = root / p.name;
    fs::create_directories(dir);
    json files = json::object(), written = json::array();
    auto put = [&](const std::string& role, const std::string& name, const Encoded& e) {
        io::write_bytes((dir / name).string(), e.bytes);
        files[role] = name;
        written.push_back(file_entry(name, e));
    };
    EncodeOptions eo;
    eo.format = p.format;
    eo.zstd = p.zstd;
    eo.writer = writer;
    const std::array<Sh9, 3> sh = p.sh_mirrored ? mirror_sh9(in.sh9, p.mirror) : in.sh9;

    json m;
    m["dir"] = p.name;
    m["description"] = p.description;
    m["container"] = container_name(p.container);
    m["format"] = pixel_format_name(p.format);
    m["supercompression"] = p.zstd ? "zstd" : "none";
    m["mirror"] = mirror_name(p.mirror);
    m["curve"] = curve_name(p.curve);

    if (p.container == Container::Source) {
        if (!in.source) throw std::logic_error("no source given for the source preset");
        io::write_exr((dir / "source.exr").string(), *in.source, io::ExrPixel::Float);
        const uint64_t clamped = io::write_hdr((dir / "source.hdr").string(), *in.source);
        files["source"] = "source.exr";
        files["source_hdr"] = "source.hdr";
        written.push_back({{"file", "source.exr"}, {"encoding", "float"}});
        written.push_back({{"file", "source.hdr"}, {"encoding", "rgbe"}, {"clamped_texels", clamped}});
        m["specular"] = json::array();
        m["lod_formula"] = nullptr;
        m["source"] = {{"width", in.source->width}, {"height", in.source->height},
                       {"orientation", "SPEC section 1 (Blender's equirectangular: centre column looks along +X)"}};
    } else {
        std::vector<const Cubemap*> cubes;
        json levels = json::array();
        for (const ExportLevel& l : in.levels) {
            if (!l.cube) throw std::logic_error("no cube given for level " + std::to_string(l.at.level) + " of preset " + p.name);
            cubes.push_back(l.cube);
            levels.push_back({{"level", l.at.level}, {"face_size", l.at.face_size}, {"roughness", l.at.roughness}});
        }
        m["specular"] = levels;
        m["lod_formula"] = lod_text(p, int(in.levels.size()), in.base_face);
        const CubeChain chain{cubes, p.mirror};
        switch (p.container) {
            case Container::Ktx2: put("specular", "specular.ktx2", encode_ktx2(chain, eo)); break;
            case Container::Dds: put("specular", "specular.dds", encode_dds(chain, eo)); break;
            case Container::Ktx1: {
                EncodeOptions k = eo;
                k.key_values.emplace_back("sh", sh_text(filament_sh(sh)));
                put("specular", "ibl.ktx", encode_ktx1(chain, k));
                if (p.skybox)
                    put("skybox", "skybox.ktx", encode_ktx1(CubeChain{{chain.levels[0]}, p.mirror}, eo));
                break;
            }
            case Container::Env: {
                EncodeOptions e = eo;
                e.polynomial = babylon_polynomial(sh);
                put("environment", "environment.env", encode_env(chain, e));
                break;
            }
            case Container::Source: break;
        }
        if (p.diffuse == DiffuseForm::Cube) {
            const Cubemap* irr = in.irradiance;
            if (!irr) throw std::logic_error("no irradiance given for preset " + p.name);
            const CubeChain d{{irr}, p.mirror};
            put("diffuse", "diffuse." + std::string(p.container == Container::Ktx2 ? "ktx2" : "dds"),
                encoder_for(p.container)(d, eo));
            m["diffuse_face_size"] = irr->size;
        }
    }
    if (p.lut) {
        const Image* lut = in.lut;
        if (!lut) throw std::logic_error("no " + std::string(lut_model_name(p.lut_model)) + " LUT given for preset " + p.name);
        const fs::path path = dir / "brdf_lut.png";
        const std::function<void()> write = [&] {
            std::vector<float> v(lut->pixels.size());
            for (size_t k = 0; k < v.size(); ++k) v[k] = std::clamp(lut->pixels[k], 0.0f, 1.0f);
            io::write_png16_fast(path.string(), lut->width, lut->height, 3, v);
        };
        if (lut_file) lut_file(*lut, "png-unorm16-zlib1-v1", path, write);
        else write();
        files["lut"] = "brdf_lut.png";
        written.push_back({{"file", "brdf_lut.png"}, {"encoding", "unorm16"}});
        m["lut"] = {{"file", "brdf_lut.png"},
                    {"size", lut->width},
                    {"model", lut_model_name(p.lut_model)},
                    {"channels", {{"r", "A (scale of F0)"}, {"g", "B (bias)"}, {"b", "0"}}},
                    {"axes", {{"x", "NdotV = (i + 0.5) / N"}, {"y", "roughness = (j + 0.5) / N, j from the top row"}}}};
    } else {
        m["lut"] = nullptr;
    }
    if (in.sun && in.sun->found) {
        const json light = engine_light(*in.sun, p);
        io::write_text((dir / "sun.json").string(), light.dump(2) + "\n");
        files["sun"] = "sun.json";
        written.push_back({{"file", "sun.json"}, {"encoding", "json"}});
        m["sun"] = light;
    }
    m["files"] = files;
    m["written"] = written;
    if (p.sh == ShForm::None) {
        m["sh"] = nullptr;
    } else if (p.sh == ShForm::BabylonPolynomial) {
        const Polynomial poly = babylon_polynomial(sh);
        m["sh"] = {{"form", sh_form_text(p)},
                   {"coefficients", {{"x", poly.x}, {"y", poly.y}, {"z", poly.z}, {"xx", poly.xx}, {"yy", poly.yy},
                                     {"zz", poly.zz}, {"yz", poly.yz}, {"zx", poly.zx}, {"xy", poly.xy}}}};
    } else {
        m["sh"] = {{"form", sh_form_text(p)},
                   {"coefficients", sh_coefficients(p.sh == ShForm::Filament ? filament_sh(sh) : sh)}};
    }
    m["diffuse"] = p.diffuse_note;
    m["notes"] = p.notes;
    return m;
}

}  // namespace

std::vector<ExportJob> export_jobs(const std::vector<ExportInput>& inputs, const fs::path& dir, const std::string& writer,
                                   const LutFileMaker& lut_file) {
    std::vector<ExportJob> jobs;
    for (const ExportInput& in : inputs)
        jobs.push_back({in.preset.name, [&in, dir, writer, lut_file] { return run_preset(in, dir, writer, lut_file); }});
    return jobs;
}

json presets_json() {
    json out = json::array();
    for (const Preset& p : preset_table()) {
        json formats = json::array();
        for (PixelFormat f : p.formats) formats.push_back(pixel_format_name(f));
        json r256 = json::array();
        for (const PresetLevel& l : preset_chain(p, 256)) r256.push_back(l.roughness);
        out.push_back({{"name", p.name},
                       {"description", p.description},
                       {"container", container_name(p.container)},
                       {"format", pixel_format_name(p.format)},
                       {"formats", formats},
                       {"supercompression", p.zstd ? "zstd" : "none"},
                       {"mirror", mirror_name(p.mirror)},
                       {"curve", curve_name(p.curve)},
                       {"lod_formula", p.lod_formula},
                       {"levels", p.container == Container::Source ? json(nullptr) : json(p.smallest == 1
                                                                      ? "N0 down to 1 x 1"
                                                                      : "N0 down to " + std::to_string(p.smallest) +
                                                                            " px")},
                       {"smallest", p.smallest},
                       {"roughness_at_256", r256},
                       {"diffuse", diffuse_name(p.diffuse)},
                       {"diffuse_note", p.diffuse_note},
                       {"sh", sh_form_name(p.sh)},
                       {"lut", p.lut ? json(lut_model_name(p.lut_model)) : json(nullptr)},
                       {"notes", p.notes}});
    }
    return out;
}

}  // namespace iblbake
