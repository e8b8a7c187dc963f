// The batch's bpy-free machinery (pipeline/batch.h) for
// blender_scripts/bake_world.py --batch: the same worlds, names, shards,
// "intact bake" check and index as the CLI's batch. Blender bakes each
// world itself (a .blend's world, an image through its Environment
// Texture), so the run loop is the caller's.
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <vector>

#include "arrays.h"
#include "bindings.h"
#include "iblbake/pipeline/batch.h"

namespace iblbake::py {

namespace {

std::vector<std::string> paths(const pybind11::iterable& items, const char* what) {
    std::vector<std::string> out;
    for (const pybind11::handle& item : items) out.push_back(path_arg(item, what));
    return out;
}

template <typename T>
T field(const pybind11::dict& d, const char* key, T fallback) {
    if (!d.contains(key) || d[key].is_none()) return fallback;
    try {
        return d[key].cast<T>();
    } catch (const pybind11::cast_error&) {
        value_error(std::string("index entry: '") + key + "' has the wrong type");
    }
}

}  // namespace

void bind_batch(pybind11::module_& m) {
    m.def(
        "batch_worlds",
        [](const pybind11::iterable& inputs, const pybind11::iterable& lists,
           const std::optional<std::vector<std::string>>& extensions, const std::string& shard) {
            std::vector<std::string> all = paths(inputs, "an input");
            for (const std::string& list : paths(lists, "a list file")) {
                const std::vector<std::string> more = batch::read_list_file(list);
                all.insert(all.end(), more.begin(), more.end());
            }
            batch::Shard s;
            try {
                if (!shard.empty()) s = batch::parse_shard(shard);
            } catch (const std::invalid_argument& e) {
                value_error(e.what());
            }
            const std::vector<batch::World> worlds =
                batch::gather_worlds(all, extensions ? *extensions : batch::image_extensions());
            pybind11::list out;
            for (const batch::World& w : batch::shard_worlds(worlds, s)) {
                pybind11::dict d;
                d["source"] = w.source;
                d["name"] = w.name;
                out.append(d);
            }
            return out;
        },
        pybind11::arg("inputs"), pybind11::arg("lists") = pybind11::list(), pybind11::arg("extensions") = pybind11::none(),
        pybind11::arg("shard") = "",
        "The worlds of a batch as the CLI's batch takes them: [{source, name}] in the batch's stable order "
        "(inputs as given, list files' lines, each folder's files with one of `extensions` sorted by name; "
        "default: the image extensions), each to be baked into OUT/<name>/; `shard` 'I/N' keeps worlds I, "
        "I+N, ... Raises RuntimeError for a missing input or an unreadable list file or folder.");

    m.def("image_extensions", [] { return batch::image_extensions(); },
          "The extensions a folder given to a batch is expanded by.");

    m.def(
        "intact_manifest",
        [](const pybind11::object& dir) -> pybind11::object {
            const std::string d = path_arg(dir, "dir");
            std::optional<nlohmann::json> m;
            {
                pybind11::gil_scoped_release release;
                m = batch::intact_manifest(d);
            }
            return m ? json_to_py(*m) : pybind11::none();
        },
        pybind11::arg("dir"),
        "The manifest of the complete, intact bake in dir (every file it lists there with its size and sha256), "
        "else None.");

    m.def(
        "write_batch_index",
        [](const pybind11::object& out, const pybind11::iterable& entries, const std::string& shard) {
            std::vector<batch::Entry> list;
            for (const pybind11::handle& h : entries) {
                if (!pybind11::isinstance<pybind11::dict>(h)) value_error("each index entry must be a dict");
                const pybind11::dict d = pybind11::reinterpret_borrow<pybind11::dict>(h);
                batch::Entry e;
                e.world = {field<std::string>(d, "source", ""), field<std::string>(d, "name", "")};
                e.status = field<std::string>(d, "status", "failed");
                if (e.status != "baked" && e.status != "unchanged" && e.status != "failed")
                    value_error("index entry: status must be baked, unchanged or failed, got '" + e.status + "'");
                e.content_hash = field<std::string>(d, "content_hash", "");
                e.error = field<std::string>(d, "error", "");
                e.seconds = field<double>(d, "seconds", 0.0);
                e.preview = field<bool>(d, "preview", false);
                e.warnings = field<std::vector<std::string>>(d, "warnings", {});
                list.push_back(std::move(e));
            }
            batch::Shard s;
            try {
                if (!shard.empty()) s = batch::parse_shard(shard);
            } catch (const std::invalid_argument& e) {
                value_error(e.what());
            }
            batch::write_index(path_arg(out, "out"), list, s);
        },
        pybind11::arg("out"), pybind11::arg("entries"), pybind11::arg("shard") = "",
        "Write out/index.json and out/index.html (a shard of several: out/index.I-of-N.json) from entries: "
        "dicts with name, source, status ('baked', 'unchanged', 'failed'), content_hash, error, warnings "
        "(a list of str), seconds, preview (bool).");
}

}  // namespace iblbake::py
