#include "iblbake/pipeline/options.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace iblbake {

namespace {

using Row = OptionRow<BakeRequest>;
using WriteRow = OptionRow<WriteOptions>;

OptionSpec spec(std::string name, OptionKind kind, std::string label, std::string help, unsigned surfaces) {
    OptionSpec s;
    s.name = std::move(name);
    s.kind = kind;
    s.label = std::move(label);
    s.help = std::move(help);
    s.surfaces = surfaces;
    s.min = 1;
    s.max = 0;
    return s;
}

// A preset's name as a UI labels it: the description's first word when it
// is the name spelled out ("three.js"), else the name capitalised.
std::string preset_label(const Preset& p) {
    std::string first = p.description.substr(0, p.description.find(' '));
    while (!first.empty() && std::strchr(",;:", first.back())) first.pop_back();
    std::string lower = first;
    for (char& c : lower) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (lower.rfind(p.name, 0) == 0) return first;
    std::string label = p.name;
    label[0] = char(std::toupper(static_cast<unsigned char>(label[0])));
    return label;
}

std::vector<WriteRow> write_rows() {
    const unsigned cli = kCli, ui = kCli | kBlender;
    std::vector<WriteRow> t;
    {
        OptionSpec s = spec("formats", OptionKind::List, "Formats", "output formats of the SPEC files", ui);
        s.cli = "--format";
        s.choices = {{"exr", "EXR", "half-float crosses (the LUT in float)"},
                     {"png", "PNG", "8-bit sRGB or RGBM crosses, the LUT in 16 bits"}};
        t.push_back({std::move(s),
                     [](WriteOptions& w, const OptionValue& v) {
                         const auto& f = std::get<std::vector<std::string>>(v);
                         w.exr = std::find(f.begin(), f.end(), "exr") != f.end();
                         w.png = std::find(f.begin(), f.end(), "png") != f.end();
                     },
                     [](const WriteOptions& w) {
                         std::vector<std::string> f;
                         if (w.exr) f.push_back("exr");
                         if (w.png) f.push_back("png");
                         return OptionValue(f);
                     }});
    }
    {
        OptionSpec s = spec("presets", OptionKind::List, "Engines",
                            "engine presets, each written into OUT/NAME (NAME:FORMAT picks a pixel format)", ui);
        s.cli = "--preset";
        s.open_choices = true;  // parse_presets checks names and modifiers
        for (const Preset& p : preset_table()) s.choices.push_back({p.name, preset_label(p), p.description});
        t.push_back({std::move(s),
                     [](WriteOptions& w, const OptionValue& v) {
                         w.presets = parse_presets(std::get<std::vector<std::string>>(v));
                     },
                     [](const WriteOptions& w) {
                         std::vector<std::string> names;
                         for (const Preset& p : w.presets) names.push_back(p.name);
                         return OptionValue(names);
                     }});
    }
    {
        OptionSpec s = spec("layout", OptionKind::Choice, "Layout", "how the SPEC cubes are laid out in OUT", cli);
        s.choices = {{"hcross", "Horizontal Cross", ""}, {"vcross", "Vertical Cross", ""}, {"faces", "Six Faces", ""},
                     {"latlong", "Lat-long", ""}};
        t.push_back({std::move(s),
                     [](WriteOptions& w, const OptionValue& v) { w.layout = layout_from_name(std::get<std::string>(v)); },
                     [](const WriteOptions& w) { return OptionValue(std::string(layout_name(w.layout))); }});
    }
    t.push_back({spec("float32", OptionKind::Bool, "Float32", "write crosses as full float instead of half", cli),
                 [](WriteOptions& w, const OptionValue& v) { w.float32 = std::get<bool>(v); },
                 [](const WriteOptions& w) { return OptionValue(w.float32); }});
    {
        OptionSpec s = spec("png_encoding", OptionKind::Choice, "PNG Encoding", "how PNG crosses hold radiance", ui);
        s.choices = {{"srgb", "sRGB 8-bit", "Clamped, exposure applied"}, {"rgbm", "RGBM", "Shared multiplier in alpha"}};
        t.push_back({std::move(s),
                     [](WriteOptions& w, const OptionValue& v) {
                         w.png_encoding = std::get<std::string>(v) == "rgbm" ? PngEncoding::Rgbm : PngEncoding::Srgb;
                     },
                     [](const WriteOptions& w) {
                         return OptionValue(std::string(w.png_encoding == PngEncoding::Rgbm ? "rgbm" : "srgb"));
                     }});
    }
    {
        OptionSpec s = spec("exposure", OptionKind::Float, "PNG Exposure", "PNG exposure in stops", ui);
        s.min = -64;
        s.max = 64;
        t.push_back({std::move(s), [](WriteOptions& w, const OptionValue& v) { w.exposure = float(std::get<double>(v)); },
                     [](const WriteOptions& w) { return OptionValue(double(w.exposure)); }});
    }
    {
        OptionSpec s = spec("rgbm_range", OptionKind::Float, "RGBM Range", "the multiplier's range of RGBM PNGs", cli);
        s.min = 0;
        s.max = 1e6;
        s.note = " (and above 0)";
        t.push_back({std::move(s), [](WriteOptions& w, const OptionValue& v) { w.rgbm_range = float(std::get<double>(v)); },
                     [](const WriteOptions& w) { return OptionValue(double(w.rgbm_range)); }});
    }
    t.push_back({spec("preview", OptionKind::Bool, "Preview Sheet",
                      "also write preview.png: irradiance, LUT, every specular level and spheres lit by the bake", ui),
                 [](WriteOptions& w, const OptionValue& v) { w.preview = std::get<bool>(v); },
                 [](const WriteOptions& w) { return OptionValue(w.preview); }});
    return t;
}

std::vector<Row> make_table() {
    std::vector<Row> t;
    for (const OptionRow<BakeOptions>& r : bake_option_rows())
        t.push_back({r.spec, [set = r.set](BakeRequest& q, const OptionValue& v) { set(q.bake, v); },
                     [get = r.get](const BakeRequest& q) { return get(q.bake); }});
    for (const WriteRow& r : write_rows())
        t.push_back({r.spec, [set = r.set](BakeRequest& q, const OptionValue& v) { set(q.write, v); },
                     [get = r.get](const BakeRequest& q) { return get(q.write); }});
    return t;
}

const char* kind_name(OptionKind k) {
    switch (k) {
        case OptionKind::Int: return "int";
        case OptionKind::Float: return "float";
        case OptionKind::Bool: return "bool";
        case OptionKind::Choice: return "choice";
        case OptionKind::List: return "list";
    }
    return "?";
}

nlohmann::json value_json(const OptionValue& v) {
    return std::visit([](const auto& x) { return nlohmann::json(x); }, v);
}

}  // namespace

void WriteOptions::validate() const {
    static const std::vector<WriteRow> rows = write_rows();
    for (const WriteRow& row : rows)
        if (row.spec.name != "presets" && row.spec.name != "formats") check_option_range(row, *this);
    if (!exr && !png) throw std::invalid_argument("no output format: ask for exr, png or both");
    if (!(rgbm_range > 0.0f)) throw std::invalid_argument("rgbm_range must be > 0 and finite");
    if (!manifest_extra.is_object()) throw std::invalid_argument("manifest_extra must be a JSON object");
    for (size_t i = 0; i < presets.size(); ++i)
        for (size_t k = 0; k < i; ++k)
            if (presets[i].name == presets[k].name)
                throw std::invalid_argument("preset '" + presets[i].name + "' is given twice");
}

const std::vector<OptionRow<BakeRequest>>& option_table() {
    static const std::vector<Row> table = make_table();
    return table;
}

const OptionRow<BakeRequest>* find_option(const std::string& name) {
    for (const Row& r : option_table())
        if (r.spec.name == name) return &r;
    return nullptr;
}

void apply_options(BakeRequest& q, const std::vector<std::pair<std::string, OptionValue>>& values,
                   const std::function<std::string(const OptionSpec&)>& spell) {
    std::vector<const OptionSpec*> given;
    for (const auto& [name, value] : values) {
        const Row* row = find_option(name);
        if (!row) throw std::invalid_argument("unknown option '" + name + "'");
        row->set(q, checked_option_value(row->spec, value));
        given.push_back(&row->spec);
    }
    // Options of the other specular method are not silently dropped.
    const std::string method = specular_method_name(q.bake.specular_method);
    const OptionSpec& method_spec = find_option("specular_method")->spec;
    for (const OptionSpec* s : given)
        if (!s->method.empty() && s->method != method)
            q.bake.warnings.push_back(spell(*s) + " applies to " + spell(method_spec) + " " + s->method +
                                      " only: ignored");
}

nlohmann::json options_json() {
    const BakeRequest defaults;
    nlohmann::json out = nlohmann::json::array();
    for (const Row& r : option_table()) {
        const OptionSpec& s = r.spec;
        nlohmann::json j = {{"name", s.name},
                            {"kind", kind_name(s.kind)},
                            {"label", s.label},
                            {"help", s.help},
                            {"default", value_json(r.get(defaults))},
                            {"cli", (s.surfaces & kCli) ? nlohmann::json(s.cli_flag()) : nlohmann::json(nullptr)},
                            {"cli_negated", s.cli_negated},
                            {"blender", (s.surfaces & kBlender) != 0},
                            {"method", s.method.empty() ? nlohmann::json(nullptr) : nlohmann::json(s.method)},
                            {"note", s.note},
                            {"open_choices", s.open_choices}};
        if (s.has_range()) {  // whole numbers for an Int (as its values are)
            auto number = [&](double v) {
                return s.kind == OptionKind::Int ? nlohmann::json(static_cast<long long>(v)) : nlohmann::json(v);
            };
            j["min"] = number(s.min);
            j["max"] = std::isinf(s.max) ? nlohmann::json(nullptr) : number(s.max);
        }
        if (!s.choices.empty()) {
            j["choices"] = nlohmann::json::array();
            for (const OptionChoice& c : s.choices)
                j["choices"].push_back({{"value", c.value}, {"label", c.label}, {"help", c.help}});
        }
        out.push_back(std::move(j));
    }
    return out;
}

}  // namespace iblbake
