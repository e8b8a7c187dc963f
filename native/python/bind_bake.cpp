// bake(), bake_file(), brdf_lut(): option parsing and array conversion.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <system_error>

#include "arrays.h"
#include "bindings.h"
#include "iblbake/bake/lut_cache.h"
#include "iblbake/export/export.h"
#include "iblbake/export/sun.h"
#include "iblbake/io/hash.h"
#include "iblbake/io/output_dir.h"
#include "iblbake/pipeline/bake_file.h"
#include "iblbake/pipeline/options.h"
#include "iblbake/pipeline/write.h"

namespace py = pybind11;

namespace iblbake::py {

namespace {

template <typename T>
T get_as(const pybind11::handle& v, const std::string& key, const char* type_name) {
    try {
        return v.cast<T>();
    } catch (const pybind11::cast_error&) {
        value_error("option '" + key + "' must be " + type_name);
    }
}

// Everything the keyword options say.
struct Parsed {
    BakePlan plan;  // made once from the options, handed to every step
    ProgressFn progress;
    std::string source_path;
    std::string source_sha256;
    std::optional<FileLutCache> cache;
    LutCache* lut_cache() { return cache ? &*cache : nullptr; }
};

ProgressFn wrap_progress(const pybind11::object& cb);

// manifest_extra: a dict of JSON values (no NaN, no infinity), as JSON.
nlohmann::json manifest_extra_json(const pybind11::handle& v) {
    if (!pybind11::isinstance<pybind11::dict>(v)) value_error("manifest_extra must be a dict");
    std::string text;
    try {
        text = pybind11::str(pybind11::module_::import("json").attr("dumps")(v, pybind11::arg("allow_nan") = false));
    } catch (const pybind11::error_already_set& e) {
        if (e.matches(PyExc_ValueError))
            value_error("manifest_extra: every number must be a finite number (JSON has no NaN or infinity)");
        // The exception's own words, one line: e.what() carries a traceback.
        std::string why = pybind11::str(e.value()).cast<std::string>();
        std::replace(why.begin(), why.end(), '\n', ' ');
        value_error("manifest_extra must hold JSON values only (dict, list, str, int, float, bool, None): " + why);
    }
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded()) value_error("manifest_extra is not valid JSON");
    return j;
}

// A keyword's value as the option's kind takes it (pipeline/options.h
// checks it further); a value of the wrong type is a ValueError naming it.
OptionValue option_value(const OptionSpec& spec, const pybind11::handle& v) {
    switch (spec.kind) {
        case OptionKind::Int: return get_as<long long>(v, spec.name, "an int");
        case OptionKind::Float: return get_as<double>(v, spec.name, "a number");
        case OptionKind::Bool: return get_as<bool>(v, spec.name, "a bool");
        case OptionKind::Choice: return get_as<std::string>(v, spec.name, "a str");
        case OptionKind::List:
            if (pybind11::isinstance<pybind11::str>(v) || pybind11::isinstance<pybind11::bytes>(v))
                value_error(spec.name + " must be a list of names (e.g. ['" + spec.choices.at(0).value + "']), not a str");
            return get_as<std::vector<std::string>>(v, spec.name, "a list of str");
    }
    value_error("option '" + spec.name + "' has no kind");
}

// Keyword options -> the plan (the options of pipeline/options.h's table) and
// what belongs to this call: progress, the source's path and hash, more
// manifest keys and warnings, why outputs are off, the LUT cache. Unknown
// keys are an error. Runs with the GIL held.
Parsed parse_options(const pybind11::dict& kw) {
    Parsed out;
    BakeRequest request;
    std::vector<std::pair<std::string, OptionValue>> given;
    std::vector<Skip> skip_reasons;
    std::vector<std::string> warnings;
    nlohmann::json manifest_extra = nlohmann::json::object();
    pybind11::object progress = pybind11::none();
    std::string lut_cache_dir;
    for (auto item : kw) {
        const std::string key = pybind11::str(item.first);
        const pybind11::handle v = item.second;
        auto as_str = [&] { return get_as<std::string>(v, key, "a str"); };
        if (const OptionRow<BakeRequest>* row = find_option(key)) {
            given.emplace_back(key, option_value(row->spec, v));
        } else if (key == "skip_reasons") {
            for (auto kv : get_as<pybind11::dict>(v, key, "a dict of output -> reason"))
                skip_reasons.push_back({pybind11::str(kv.first), pybind11::str(kv.second)});
        } else if (key == "progress") {
            if (!v.is_none() && !pybind11::isinstance<pybind11::function>(v)) value_error("progress must be callable");
            progress = pybind11::reinterpret_borrow<pybind11::object>(v);
        } else if (key == "source_path") {
            out.source_path = v.is_none() ? std::string() : as_str();
        } else if (key == "source_sha256") {
            out.source_sha256 = v.is_none() ? std::string() : as_str();
            const bool hex = std::all_of(out.source_sha256.begin(), out.source_sha256.end(),
                                         [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
            if (!out.source_sha256.empty() && (out.source_sha256.size() != 64 || !hex))
                value_error("source_sha256 must be 64 hex digits (the sha256 of the RGB float32 pixels)");
        } else if (key == "manifest_extra") {
            manifest_extra = manifest_extra_json(v);
        } else if (key == "warnings") {
            warnings = get_as<std::vector<std::string>>(v, key, "a list of str");
        } else if (key == "lut_cache_dir") {
            lut_cache_dir = v.is_none() ? std::string() : as_str();
        } else {
            value_error("unknown option '" + key + "'");
        }
    }
    apply_options(request, given, [](const OptionSpec& s) { return s.name; });
    request.bake.skip_reasons = std::move(skip_reasons);
    request.bake.warnings.insert(request.bake.warnings.begin(), warnings.begin(), warnings.end());
    request.write.manifest_extra = std::move(manifest_extra);
    // Validates the options; a preset they cannot serve fails here.
    out.plan = make_plan(std::move(request.bake), std::move(request.write));
    out.progress = wrap_progress(progress);
    if (!lut_cache_dir.empty()) out.cache.emplace(lut_cache_dir);
    return out;
}

// A progress callback that may be called from any thread with the GIL
// released. Ctrl-C is honoured here too (PyErr_CheckSignals, in the main
// thread): the bake then unwinds, removes its staging folder and bake()
// raises KeyboardInterrupt. The callback returns True or None to go on and
// False to cancel; anything else is a TypeError.
ProgressFn wrap_progress(const pybind11::object& cb) {
    return [cb](const std::string& stage, double f) {
        pybind11::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) throw pybind11::error_already_set();
        if (cb.is_none()) return true;
        const pybind11::object r = cb(stage, f);
        if (r.is_none()) return true;
        if (pybind11::isinstance<pybind11::bool_>(r) ||
            pybind11::isinstance(r, pybind11::module_::import("numpy").attr("bool_")))
            return bool(pybind11::bool_(r));
        throw pybind11::type_error("progress callback must return True or None (go on) or False (cancel), got " +
                                   std::string(pybind11::str(pybind11::type::of(r).attr("__name__"))));
    };
}

}  // namespace

pybind11::object json_to_py(const nlohmann::json& j) {
    return pybind11::module_::import("json").attr("loads")(j.dump());
}

namespace {

pybind11::dict result_dict(const BakeResult& r) {
    pybind11::dict d;
    d["irradiance"] = r.irradiance ? pybind11::object(cube_array(*r.irradiance)) : pybind11::none();
    pybind11::list spec;
    for (const Cubemap& c : r.specular) spec.append(cube_array(c));
    d["specular"] = spec;
    d["specular_levels"] = r.specular_levels;
    d["roughness"] = r.roughness;
    d["brdf_lut"] = r.lut ? pybind11::object(image_array(*r.lut)) : pybind11::none();
    pybind11::array_t<double> sh({3, 9});
    for (int c = 0; c < 3; ++c)
        for (int i = 0; i < 9; ++i) sh.mutable_at(c, i) = r.sh9[c][i];
    d["sh9"] = sh;
    pybind11::dict bad;
    bad["nan"] = r.bad_input.nan;
    bad["inf"] = r.bad_input.inf;
    bad["negative"] = r.bad_input.negative;
    bad["pixels"] = r.bad_input.pixels;
    d["bad_input"] = bad;
    pybind11::dict timings;
    for (const auto& [k, v] : r.timings) timings[pybind11::str(k)] = v;
    d["timings"] = timings;
    d["hot_texels"] = r.hot_texels;
    d["sun"] = r.sun ? json_to_py(sun_json(*r.sun)) : pybind11::none();
    return d;
}

}  // namespace

// A path argument: str, os.PathLike or bytes (file system encoding, so a
// name that is not UTF-8 round-trips); anything else is a TypeError.
std::string path_arg(const pybind11::handle& v, const char* what) {
    const pybind11::module_ os = pybind11::module_::import("os");
    if (!pybind11::isinstance<pybind11::str>(v) && !pybind11::isinstance<pybind11::bytes>(v) &&
        !pybind11::hasattr(v, "__fspath__"))
        throw pybind11::type_error(std::string(what) + " must be a str, bytes or os.PathLike path, got " +
                                   std::string(pybind11::str(pybind11::type::of(v).attr("__name__"))));
    return os.attr("fsencode")(v).cast<std::string>();
}

namespace {

// bake() and bake_constant()'s out_dir: "" for none; checked with the GIL
// held, before any work, so that a refused folder costs nothing.
std::string checked_out_dir(const pybind11::object& out_dir, const Parsed& p) {
    if (out_dir.is_none()) {
        if (!p.plan.write.presets.empty()) value_error("presets write files: give an out_dir");
        return {};
    }
    const std::string out = path_arg(out_dir, "out_dir");
    if (out.empty()) value_error("out_dir must be a non-empty path, or None to write nothing");
    p.plan.write.validate();
    io::check_replaceable(out, p.source_path);
    return out;
}

// Runs `compute(src) -> BakeResult` without the GIL, writes the files when
// `out` is given, and returns the result dict with the manifest.
template <typename Compute>
pybind11::dict run_bake(Parsed& p, const std::string& out, SourceInfo src, Compute&& compute) {
    BakeResult r;
    nlohmann::json manifest;
    {
        pybind11::gil_scoped_release release;
        r = compute(src);
        manifest = out.empty() ? make_manifest(r, p.plan, src, nlohmann::json::object())
                               : write_bake(r, out, p.plan, src, p.progress, p.lut_cache());
    }
    pybind11::dict d = result_dict(r);
    d["manifest"] = json_to_py(manifest);
    return d;
}

}  // namespace

void bind_bake(pybind11::module_& m) {
    m.def(
        "bake",
        [](const pybind11::handle& image, const pybind11::object& out_dir, const pybind11::kwargs& kw) {
            Parsed p = parse_options(kw);
            const PixelArray pixels(image);
            const std::string out = checked_out_dir(out_dir, p);
            SourceInfo src;
            src.path = p.source_path;
            src.sha256 = p.source_sha256;
            src.width = pixels.width();
            src.height = pixels.height();
            return run_bake(p, out, src, [&](SourceInfo& s) {
                // An RGB array is integrated where it lies; RGBA is copied to
                // RGB, and that copy is the bake's own (cleaned in place, freed early).
                Image rgb;
                if (!pixels.is_rgb()) rgb = pixels.to_image();
                const ImageView view = pixels.is_rgb() ? pixels.view() : ImageView(rgb);
                // The manifest's hash: the caller's, else the file's when the
                // pixels came from one (as the CLI), else the pixels'. Only a
                // written bake pays for it (100 MB of pixels take 80 ms).
                if (s.sha256.empty() && !out.empty()) {
                    std::error_code ec;
                    s.sha256 = !s.path.empty() && std::filesystem::is_regular_file(s.path, ec)
                                   ? io::sha256_file(s.path)
                                   : io::sha256_bytes(view.data, view.value_count() * sizeof(float));
                }
                return pixels.is_rgb() ? compute_bake_view(view, p.plan.bake, p.progress, p.lut_cache())
                                       : compute_bake(std::move(rgb), p.plan.bake, p.progress, p.lut_cache());
            });
        },
        pybind11::arg("image"), pybind11::arg("out_dir") = pybind11::none(),
        R"doc(Bake IBL from a lat-long float32 array (H, W, 3 or 4), rows top to bottom, Blender world space.

With out_dir, writes SPEC.md's files there atomically. Always returns a dict with
'irradiance' (6, N, N, 3), 'specular' (list of (6, n, n, 3)), 'roughness', 'brdf_lut' (N, N, 3),
'specular_levels', 'sh9' (3, 9), 'bad_input', 'timings', 'sun' (with sun='split': sun.json's content, else None) and
'manifest'. Options (keywords): every row of
options() (face_size, formats, presets, ...: the CLI's options), and for this call: progress (callable(stage,
fraction) -> bool; False cancels), source_path, source_sha256 (the manifest's hash, when the caller has it already;
else a written bake hashes the file or the pixels, and an unwritten one leaves it null), lut_cache_dir (a folder
where BRDF LUTs are reused across bakes; none by default), manifest_extra (a dict of more top-level manifest keys),
warnings (a list of str the manifest's warnings start with), skip_reasons (a dict: output -> why it is off).
Raises ValueError on a wrong dtype, shape or option, or on bad pixels with strict=True.)doc");

    m.def(
        "bake_constant",
        [](const std::array<float, 3>& rgb, const pybind11::object& out_dir, const pybind11::kwargs& kw) {
            Parsed p = parse_options(kw);
            const std::string out = checked_out_dir(out_dir, p);
            SourceInfo src;
            src.path = p.source_path;
            src.width = src.height = 1;
            return run_bake(p, out, src, [&](SourceInfo& s) {
                s.sha256 = io::sha256_bytes(rgb.data(), sizeof(rgb));
                return compute_constant_bake(rgb, p.plan.bake, p.progress, p.lut_cache());
            });
        },
        pybind11::arg("rgb"), pybind11::arg("out_dir") = pybind11::none(),
        "Bake a constant world of radiance rgb in closed form (no integration); same options and result as bake().");

    m.def(
        "presets", [] { return json_to_py(presets_json()); },
        "The engine presets (docs/export.md) as a list of dicts: name, description, container, format, formats, "
        "supercompression, mirror, curve, lod_formula, levels, smallest, roughness_at_256, diffuse, diffuse_note, sh, "
        "lut, notes.");

    m.def(
        "options", [] { return json_to_py(options_json()); },
        "The bake's options, the table the CLI, bake_world.py and the add-on are made from: a list of dicts with "
        "name (the keyword bake() takes), kind ('int', 'float', 'bool', 'choice', 'list'), label, help, default, "
        "min and max (numbers with a range), choices ([{value, label, help}]), cli (the CLI's flag, or None), "
        "cli_negated, blender (offered in Blender), method, note.");

    m.def("default_lut_cache_dir", [] { return FileLutCache::default_dir().string(); },
          "The CLI's LUT cache folder: $IBLBAKE_CACHE_DIR, else $XDG_CACHE_HOME/iblbake, else ~/.cache/iblbake.");

    m.def(
        "check_options",
        [](const pybind11::kwargs& kw) {
            Parsed p = parse_options(kw);
            p.plan.write.validate();
        },
        "Raise ValueError, with the CLI's message, if bake()'s keyword options are not valid; do nothing else.");

    m.def(
        "bake_file",
        [](const pybind11::object& source_obj, const pybind11::object& out_obj, const pybind11::kwargs& kw) {
            const std::string source = path_arg(source_obj, "source"), out_dir = path_arg(out_obj, "out_dir");
            Parsed p = parse_options(kw);
            nlohmann::json manifest;
            {
                pybind11::gil_scoped_release release;
                manifest = bake_file(source, out_dir, p.plan, p.progress, p.lut_cache());
            }
            return json_to_py(manifest);
        },
        pybind11::arg("source"), pybind11::arg("out_dir"),
        "Bake an image file into out_dir (the CLI's bake); returns the manifest. Same options as bake().");

    m.def(
        "brdf_lut",
        [](int size, const std::string& model, int phi_points, int u_points, int threads, int row_nodes) {
            if (size < 1 || size > 8192) value_error("size must be in 1..8192");
            if (phi_points < 1 || u_points < 1) value_error("quadrature orders must be >= 1");
            if (row_nodes != 0 && (row_nodes < 4 || row_nodes > 4096)) value_error("row_nodes must be 0 or in 4..4096");
            const LutModel mdl = lut_model_from_name(model);
            Image lut;
            {
                pybind11::gil_scoped_release release;
                lut = compute_lut(size, mdl, LutQuality{phi_points, u_points, row_nodes}, threads);
            }
            return image_array(lut);
        },
        pybind11::arg("size") = 512, pybind11::arg("model") = "karis", pybind11::arg("phi_points") = 4,
        pybind11::arg("u_points") = 6, pybind11::arg("threads") = 0, pybind11::arg("row_nodes") = 64,
        "The BRDF LUT alone, (size, size, 3). row_nodes: 0 integrates every texel; k >= 4 integrates k nodes per "
        "row and fills the rest from a cubic spline.");

    m.def(
        "integrate_brdf",
        [](double ndotv, double roughness, const std::string& model, int phi_points, int u_points) {
            if (phi_points < 1 || u_points < 1 || phi_points > 256 || u_points > 256)
                value_error("quadrature orders must be in 1..256");
            const LutValue v = integrate_brdf(ndotv, roughness, lut_model_from_name(model), {phi_points, u_points});
            return pybind11::make_tuple(v.a, v.b);
        },
        pybind11::arg("ndotv"), pybind11::arg("roughness"), pybind11::arg("model") = "karis",
        pybind11::arg("phi_points") = 4, pybind11::arg("u_points") = 6, "(A, B) at one point.");
}

}  // namespace iblbake::py
