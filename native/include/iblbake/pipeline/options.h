// Every option of a bake as one table (bake/options.h says why): BakeOptions'
// rows, then WriteOptions' (formats, presets, layout, PNG encoding, the
// preview). The CLI registers its flags from it, the Python module checks its
// keyword arguments with it and returns it as iblbake_core.options(), and
// Blender's side builds its argparse, properties and option rows from that.
// Arguments that belong to one call rather than to the bake (the CLI's
// source, output folder and cache folder; Python's progress callback,
// source hash, manifest_extra) are not options and stay with their surface.
#pragma once
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "iblbake/bake/options.h"
#include "iblbake/pipeline/plan.h"

namespace iblbake {

// What the options set.
struct BakeRequest {
    BakeOptions bake;
    WriteOptions write;
};

// The whole table, BakeOptions' rows first.
const std::vector<OptionRow<BakeRequest>>& option_table();
// The row named `name` (Python's keyword), or nullptr.
const OptionRow<BakeRequest>* find_option(const std::string& name);

// Sets each (name, value) in order and checks it (std::invalid_argument
// names the option); an unknown name is an error. An option of the other
// specular method is set but adds a warning to the bake ("eps applies to
// specular_method hierarchical only: ignored"), spelled as `spell` shows the
// option's name (the CLI: its flag).
void apply_options(BakeRequest& request, const std::vector<std::pair<std::string, OptionValue>>& values,
                   const std::function<std::string(const OptionSpec&)>& spell);

// The table as JSON, one object per row: name, kind ("int", "float", "bool",
// "choice", "list"), label, help, default, min and max (numbers with a
// range), choices ([{value, label, help}]), open_choices, cli (the flag, or
// null), cli_negated, blender (offered in Blender), method, note.
nlohmann::json options_json();

}  // namespace iblbake
