// The bake's options as one table: a row per option with its name, kind,
// range or choices, one-line help, where it is offered, and the setter and
// getter of its field. Every surface is made from the table: the CLI
// registers its flags (native/cli/main.cpp), the Python module checks its
// keyword arguments and returns the table (iblbake_core.options()), and
// Blender's side (blender_scripts/bake_world.py's argparse, the add-on's
// properties and option rows) is built from that. A new option is one row
// here (or in pipeline/options.h, for what is written) plus its use.
//
// This part holds the rows of BakeOptions (what is integrated and how);
// pipeline/options.h adds WriteOptions' rows and the table as a whole.
// BakeOptions::validate() checks each row's range from here.
#pragma once
#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "iblbake/bake/bake.h"

namespace iblbake {

enum class OptionKind { Int, Float, Bool, Choice, List };

// A value as a surface hands it over: the CLI's text is parsed into one
// (parse_option_text), Python's objects are converted into one.
using OptionValue = std::variant<bool, long long, double, std::string, std::vector<std::string>>;

struct OptionChoice {
    std::string value, label, help;
};

// Where an option is offered besides Python (which takes every row).
enum OptionSurface : unsigned { kCli = 1, kBlender = 2 };

struct OptionSpec {
    std::string name;   // Python's keyword and the add-on's property, e.g. "face_size"
    OptionKind kind;
    std::string label;  // as a UI shows it, e.g. "Specular Size"
    std::string help;   // one line
    double min = 0, max = 0;  // Int and Float: the inclusive range (min > max: any finite value)
    std::vector<OptionChoice> choices;  // Choice and List: the values taken
    bool open_choices = false;  // the setter checks the values (a preset may carry modifiers: "khronos:rgba32f")
    unsigned surfaces = kCli;
    std::string cli;        // the CLI's flag; empty: "--" + name with '-' for '_'
    bool cli_negated = false;  // a Bool the CLI offers as --no-<name> (its default is true)
    std::string method;     // "fis" or "hierarchical": ignored (with a warning) under the other method
    std::string note;       // appended to the range in messages, e.g. "(0: the full chain)"
    std::string cli_flag() const;
    bool has_range() const { return min <= max; }
};

template <typename Target>
struct OptionRow {
    OptionSpec spec;
    std::function<void(Target&, const OptionValue&)> set;  // the value is of the row's kind, checked
    std::function<OptionValue(const Target&)> get;
};

// BakeOptions' rows, in the order help lists them.
const std::vector<OptionRow<BakeOptions>>& bake_option_rows();

// A value of the row's kind from a surface's value: an Int from a whole
// number, a Float from any number, a Choice or List checked against the
// choices, a range checked; throws std::invalid_argument naming the option.
OptionValue checked_option_value(const OptionSpec& spec, const OptionValue& value);
// The CLI's text of a value ("256", "0.5", "exr,png"); Bools take
// true/false/1/0/yes/no/on/off.
OptionValue parse_option_text(const OptionSpec& spec, const std::string& text);
// How help and error messages show a value.
std::string option_value_text(const OptionValue& value);

// Throws std::invalid_argument when `target`'s value of the row is out of
// its range or choices (BakeOptions::validate(), WriteOptions::validate()).
template <typename Target>
void check_option_range(const OptionRow<Target>& row, const Target& target) {
    checked_option_value(row.spec, row.get(target));
}

}  // namespace iblbake
