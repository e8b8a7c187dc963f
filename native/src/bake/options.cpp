#include "iblbake/bake/options.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <utility>

namespace iblbake {

namespace {

using Row = OptionRow<BakeOptions>;
constexpr double kAny = std::numeric_limits<double>::infinity();

[[noreturn]] void bad(const OptionSpec& s, const std::string& why) { throw std::invalid_argument(s.name + " " + why); }

std::string number_text(double v) {
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return buf;
}

// Rows of every kind, each naming the BakeOptions field it sets.
Row int_row(OptionSpec s, int BakeOptions::*field) {
    s.kind = OptionKind::Int;
    return {std::move(s), [field](BakeOptions& o, const OptionValue& v) { o.*field = int(std::get<long long>(v)); },
            [field](const BakeOptions& o) { return OptionValue(static_cast<long long>(o.*field)); }};
}
template <typename Part>
Row int_row(OptionSpec s, Part BakeOptions::*part, int Part::*field) {
    s.kind = OptionKind::Int;
    return {std::move(s),
            [part, field](BakeOptions& o, const OptionValue& v) { (o.*part).*field = int(std::get<long long>(v)); },
            [part, field](const BakeOptions& o) { return OptionValue(static_cast<long long>((o.*part).*field)); }};
}
template <typename Part, typename T>
Row float_row(OptionSpec s, Part BakeOptions::*part, T Part::*field) {
    s.kind = OptionKind::Float;
    return {std::move(s), [part, field](BakeOptions& o, const OptionValue& v) { (o.*part).*field = T(std::get<double>(v)); },
            [part, field](const BakeOptions& o) { return OptionValue(double((o.*part).*field)); }};
}
Row float_row(OptionSpec s, double BakeOptions::*field) {
    s.kind = OptionKind::Float;
    return {std::move(s), [field](BakeOptions& o, const OptionValue& v) { o.*field = std::get<double>(v); },
            [field](const BakeOptions& o) { return OptionValue(o.*field); }};
}
Row bool_row(OptionSpec s, bool BakeOptions::*field) {
    s.kind = OptionKind::Bool;
    return {std::move(s), [field](BakeOptions& o, const OptionValue& v) { o.*field = std::get<bool>(v); },
            [field](const BakeOptions& o) { return OptionValue(o.*field); }};
}

OptionSpec spec(std::string name, std::string label, std::string help, unsigned surfaces) {
    OptionSpec s;
    s.name = std::move(name);
    s.label = std::move(label);
    s.help = std::move(help);
    s.surfaces = surfaces;
    s.min = 1;
    s.max = 0;  // no range unless given
    return s;
}
OptionSpec ranged(OptionSpec s, double min, double max, std::string note = "") {
    s.min = min;
    s.max = max;
    s.note = std::move(note);
    return s;
}
OptionSpec for_method(OptionSpec s, const char* method) {
    s.method = method;
    return s;
}

std::vector<Row> make_rows() {
    std::vector<Row> t;
    const unsigned cli = kCli, ui = kCli | kBlender, py = 0;
    t.push_back(int_row(ranged(spec("face_size", "Specular Size", "face size of specular mip 0", ui), 1, 4096),
                        &BakeOptions::face_size));
    t.push_back(int_row(ranged(spec("irradiance_size", "Irradiance Size", "face size of the irradiance cube", ui), 1, 4096),
                        &BakeOptions::irradiance_size));
    {
        OptionSpec s = ranged(spec("mip_count", "Mip Levels", "specular mip levels (0: the full chain down to 1 x 1)", ui),
                              0, 20, " (0: the full chain)");
        s.cli = "--mips";
        t.push_back(int_row(std::move(s), &BakeOptions::mip_count));
    }
    t.push_back(int_row(ranged(spec("first_level", "First Level", "bake specular levels from this one on", py), 0, 19),
                        &BakeOptions::first_level));
    t.push_back(int_row(ranged(spec("last_level", "Last Level", "bake specular levels up to this one", py), -1, 19,
                               " (-1: the last)"),
                        &BakeOptions::last_level));
    t.push_back(int_row(ranged(spec("lut_size", "LUT Size", "BRDF LUT size (N x N)", ui), 1, 4096), &BakeOptions::lut_size));
    {
        OptionSpec s = spec("lut_model", "LUT Model", "BRDF LUT model", ui);
        s.kind = OptionKind::Choice;
        s.choices = {{"karis", "Karis (UE4)", "GGX, Smith-Schlick k = alpha/2: the seeds' and UE4's LUT"},
                     {"height-correlated", "Height-correlated", "GGX with height-correlated Smith visibility"},
                     {"multiscatter", "Multiple scattering",
                      "Height-correlated, written for Turquin's energy compensation"}};
        t.push_back({std::move(s),
                     [](BakeOptions& o, const OptionValue& v) { o.lut_model = lut_model_from_name(std::get<std::string>(v)); },
                     [](const BakeOptions& o) { return OptionValue(std::string(lut_model_name(o.lut_model))); }});
    }
    for (auto [name, label, help, field] : {std::tuple{"irradiance", "Irradiance", "bake the diffuse irradiance cube",
                                                       &BakeOptions::irradiance},
                                            std::tuple{"specular", "Specular", "bake the prefiltered specular chain",
                                                       &BakeOptions::specular},
                                            std::tuple{"lut", "BRDF LUT", "bake (or reuse) the split-sum BRDF LUT",
                                                       &BakeOptions::lut}}) {
        OptionSpec s = spec(name, label, help, ui);
        s.cli_negated = true;
        t.push_back(bool_row(std::move(s), field));
    }
    {
        OptionSpec s = spec("specular_method", "Specular Method", "how the specular levels are integrated", cli);
        s.kind = OptionKind::Choice;
        s.choices = {{"hierarchical", "Hierarchical", "deterministic kernel sum over exact bins"},
                     {"fis", "FIS", "filtered importance sampling (kept for comparison)"}};
        t.push_back({std::move(s),
                     [](BakeOptions& o, const OptionValue& v) {
                         o.specular_method = specular_method_from_name(std::get<std::string>(v));
                     },
                     [](const BakeOptions& o) { return OptionValue(std::string(specular_method_name(o.specular_method))); }});
    }
    t.push_back(float_row(
        for_method(ranged(spec("eps", "Specular Eps", "bin size against the kernel's length scale; error grows as eps^3", cli),
                          0.02, 2.0,
                          " (the default 0.5 keeps every texel within about 0.4 %; error grows as eps^3 to eps^4)"),
                   "hierarchical"),
        &BakeOptions::hierarchical, &HierarchicalQuality::eps));
    t.push_back(int_row(for_method(ranged(spec("tile", "Tile", "output texels per traversal, across", py), 0, 256,
                                          " (0: automatic)"),
                                   "hierarchical"),
                        &BakeOptions::hierarchical, &HierarchicalQuality::tile));
    t.push_back(int_row(for_method(ranged(spec("rings", "Rings", "quadrature rings per texel", cli), 1, 256), "fis"),
                        &BakeOptions::specular_quality, &SpecularQuality::rings));
    t.push_back(int_row(for_method(ranged(spec("min_phi", "Min Phi", "azimuthal samples per ring, at least", py), 1, 4096), "fis"),
                        &BakeOptions::specular_quality, &SpecularQuality::min_phi));
    t.push_back(int_row(for_method(ranged(spec("max_phi", "Max Phi", "azimuthal samples per ring, at most", py), 1, 4096), "fis"),
                        &BakeOptions::specular_quality, &SpecularQuality::max_phi));
    {
        // A shorthand for rings and max_phi; its value is what they amount to.
        OptionSpec s = for_method(
            ranged(spec("samples", "Samples", "samples per texel, approximately (sets rings to sqrt(S)/2 and the "
                                              "azimuthal cap to 2 sqrt(S))", cli),
                   1, 262144),
            "fis");
        s.kind = OptionKind::Int;
        t.push_back({std::move(s),
                     [](BakeOptions& o, const OptionValue& v) {
                         const double root = std::sqrt(double(std::get<long long>(v)));
                         o.specular_quality.rings = std::max(1, int(std::lround(root / 2.0)));
                         o.specular_quality.max_phi = std::max(o.specular_quality.min_phi, int(std::lround(2.0 * root)));
                     },
                     [](const BakeOptions& o) {
                         const long long r = o.specular_quality.rings;
                         return OptionValue(4 * r * r);
                     }});
    }
    t.push_back(float_row(for_method(ranged(spec("lod_bias", "LOD Bias", "mip bias of filtered lookups", cli), -16, 16), "fis"),
                          &BakeOptions::specular_quality, &SpecularQuality::lod_bias));
    t.push_back(int_row(for_method(ranged(spec("specular_base_face", "Base Face", "rest cube face (a power of two)", py), 0,
                                          4096, " (0: automatic)"),
                                   "fis"),
                        &BakeOptions::specular_base_face));
    t.push_back(int_row(ranged(spec("irradiance_bins", "Irradiance Bins", "lat-long bins across (a power of two)", py), 2, 4096),
                        &BakeOptions::irradiance_bins));
    t.push_back(int_row(ranged(spec("irradiance_exact_face", "Irradiance Exact Face",
                                    "larger irradiance faces are resampled from this one", py),
                               1, 4096),
                        &BakeOptions::irradiance_exact_face));
    t.push_back(int_row(ranged(spec("lut_phi_points", "LUT Phi Points", "Gauss-Legendre nodes per azimuth panel", py), 1, 256),
                        &BakeOptions::lut_quality, &LutQuality::phi_points));
    t.push_back(int_row(ranged(spec("lut_u_points", "LUT U Points", "Gauss-Legendre nodes per theta_h panel", py), 1, 256),
                        &BakeOptions::lut_quality, &LutQuality::u_points));
    t.push_back(int_row(ranged(spec("lut_row_nodes", "LUT Row Nodes",
                                    "integrals per LUT row, a spline between (0: every texel, else at least 4)", py),
                               0, 4096),
                        &BakeOptions::lut_quality, &LutQuality::row_nodes));
    t.push_back(float_row(ranged(spec("hot_threshold", "Hot Threshold",
                                      "texels brighter than this times the mean are integrated exactly", cli),
                                 1, kAny),
                          &BakeOptions::hot_threshold));
    t.push_back(int_row(ranged(spec("max_hot", "Max Hot", "at most this many exactly integrated texels", cli), 0, 1 << 20),
                        &BakeOptions::max_hot));
    t.push_back(float_row(ranged(spec("rotation", "Rotation",
                                      "turn the world about its up axis, in degrees, as Blender's Mapping node "
                                      "(Point, Z) turns an Environment Texture", cli),
                                 -360, 360),
                          &BakeOptions::rotation));
    {
        OptionSpec s = spec("sun", "Sun",
                            "the dominant compact light (the sun) as a directional light of its own, every output "
                            "baked from the environment without it (sun.json, sun.gltf)",
                            ui);
        s.kind = OptionKind::Choice;
        s.choices = {{"off", "Off", "bake the environment as it is"},
                     {"split", "Split",
                      "find the sun, bake the environment without it and export it as a light (or say why there is none)"}};
        t.push_back({std::move(s),
                     [](BakeOptions& o, const OptionValue& v) { o.sun = sun_mode_from_name(std::get<std::string>(v)); },
                     [](const BakeOptions& o) { return OptionValue(std::string(sun_mode_name(o.sun))); }});
    }
    t.push_back(bool_row(spec("strict", "Strict", "fail on NaN, Inf or negative source values instead of zeroing them", cli),
                         &BakeOptions::strict));
    t.push_back(int_row(ranged(spec("threads", "Threads", "worker threads", cli), 0, 1024, " (0: all cores)"),
                        &BakeOptions::threads));
    return t;
}

bool whole(double v) { return std::isfinite(v) && v == std::floor(v) && std::fabs(v) < 9.0e15; }

void check_choice(const OptionSpec& s, const std::string& v) {
    for (const OptionChoice& c : s.choices)
        if (c.value == v) return;
    std::string all;
    for (const OptionChoice& c : s.choices) all += (all.empty() ? "" : ", ") + c.value;
    bad(s, "'" + v + "' is not one of " + all);
}

}  // namespace

std::string OptionSpec::cli_flag() const {
    if (!cli.empty()) return cli;
    std::string f = "--" + std::string(cli_negated ? "no-" : "") + name;
    std::replace(f.begin(), f.end(), '_', '-');
    return f;
}

const std::vector<OptionRow<BakeOptions>>& bake_option_rows() {
    static const std::vector<Row> rows = make_rows();
    return rows;
}

OptionValue checked_option_value(const OptionSpec& s, const OptionValue& value) {
    switch (s.kind) {
        case OptionKind::Bool:
            if (!std::holds_alternative<bool>(value)) bad(s, "must be true or false");
            return value;
        case OptionKind::Int:
        case OptionKind::Float: {
            double v;
            if (std::holds_alternative<long long>(value)) v = double(std::get<long long>(value));
            else if (std::holds_alternative<double>(value)) v = std::get<double>(value);
            else bad(s, s.kind == OptionKind::Int ? "must be a whole number" : "must be a number");
            if (!std::isfinite(v)) bad(s, "must be a finite number");
            if (s.kind == OptionKind::Int && !whole(v)) bad(s, "must be a whole number, not " + number_text(v));
            if (s.has_range() && (v < s.min || v > s.max))
                bad(s, std::isinf(s.max) ? "must be >= " + number_text(s.min)
                                         : "must be in " + number_text(s.min) + ".." + number_text(s.max) + s.note);
            return s.kind == OptionKind::Int ? OptionValue(static_cast<long long>(v)) : OptionValue(v);
        }
        case OptionKind::Choice:
            if (!std::holds_alternative<std::string>(value)) bad(s, "must be a name");
            if (!s.open_choices) check_choice(s, std::get<std::string>(value));
            return value;
        case OptionKind::List:
            if (!std::holds_alternative<std::vector<std::string>>(value)) bad(s, "must be a list of names");
            if (!s.open_choices)
                for (const std::string& v : std::get<std::vector<std::string>>(value)) check_choice(s, v);
            return value;
    }
    return value;
}

OptionValue parse_option_text(const OptionSpec& s, const std::string& text) {
    switch (s.kind) {
        case OptionKind::Bool: {
            std::string t = text;
            for (char& c : t) c = char(std::tolower(static_cast<unsigned char>(c)));
            if (t == "1" || t == "true" || t == "yes" || t == "on") return true;
            if (t == "0" || t == "false" || t == "no" || t == "off") return false;
            bad(s, "must be true or false, not '" + text + "'");
        }
        case OptionKind::Int:
        case OptionKind::Float: {
            errno = 0;
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
                bad(s, std::string(s.kind == OptionKind::Int ? "must be a whole number" : "must be a number") +
                           ", not '" + text + "'");
            return checked_option_value(s, s.kind == OptionKind::Int && whole(v) ? OptionValue(static_cast<long long>(v))
                                                                                  : OptionValue(v));
        }
        case OptionKind::Choice:
            return checked_option_value(s, text);
        case OptionKind::List: {
            std::vector<std::string> items;
            size_t start = 0;
            for (;;) {
                const size_t comma = text.find(',', start);
                items.push_back(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
                if (comma == std::string::npos) break;
                start = comma + 1;
            }
            return checked_option_value(s, items);
        }
    }
    return text;
}

std::string option_value_text(const OptionValue& value) {
    if (std::holds_alternative<bool>(value)) return std::get<bool>(value) ? "true" : "false";
    if (std::holds_alternative<long long>(value)) return std::to_string(std::get<long long>(value));
    if (std::holds_alternative<double>(value)) return number_text(std::get<double>(value));
    if (std::holds_alternative<std::string>(value)) return std::get<std::string>(value);
    std::string all;
    for (const std::string& s : std::get<std::vector<std::string>>(value)) all += (all.empty() ? "" : ",") + s;
    return all;
}

}  // namespace iblbake
