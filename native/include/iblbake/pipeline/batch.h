// Many worlds in one command (docs/cli.md, docs/farm.md): which worlds a
// batch holds and in what order, the folder each bakes into, every N-th of
// them for one shard of a farm, the content hash that tells an unchanged
// bake from a stale one, the run itself (bake_file per world, several at
// once with `jobs`) and OUT/index.json + OUT/index.html.
//
// One implementation for both front ends: the CLI runs run_batch(); the
// Python module hands gather_worlds(), shard_worlds(), intact_manifest() and
// write_index() to blender_scripts/bake_world.py --batch (which bakes each
// world through Blender), so a folder's names, a shard's worlds and the
// index are the same whichever baked them.
#pragma once
#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "iblbake/bake/lut_cache.h"
#include "iblbake/pipeline/options.h"

namespace iblbake::batch {

struct World {
    std::string source;  // as given (a folder's files: folder / file name)
    std::string name;    // OUT/<name>/: unique in the batch (name_worlds)
};

// What a folder given as an input is expanded to (lowercase extensions).
const std::vector<std::string>& image_extensions();

// A list file's inputs: one path a line; blank lines and lines starting
// with '#' are skipped; a relative path is relative to the list file's
// folder. Throws std::runtime_error when it cannot be read.
std::vector<std::string> read_list_file(const std::string& path);

// The batch's worlds in its stable order: the inputs in the order given
// (list files' lines where they stand), each folder replaced by its files
// with one of `extensions` (not recursive, sorted by file name bytewise).
// The same file given twice (same canonical path) is one world. Names from
// name_worlds(). A missing or unreadable file is a world that fails when
// baked (the others go on); a folder that cannot be listed throws
// std::runtime_error.
std::vector<World> gather_worlds(const std::vector<std::string>& inputs,
                                 const std::vector<std::string>& extensions = image_extensions());

// A file name's stem as a folder name: bytes other than ASCII letters,
// digits, '-', '_' and '.' become '_', leading dots and trailing dots or
// spaces are dropped, at most 100 bytes; "world" when nothing is left.
std::string safe_name(const std::string& stem);

// Sets each world's name: safe_name(stem), unless another world of the
// batch has the same one (compared without case: forest.exr and
// Forest.hdr, or a/forest.exr and b/forest.exr): then each of them is
// "<safe>-<8 hex digits of the sha256 of its absolute path>", so neither
// overwrites the other and a name does not depend on the inputs' order.
void name_worlds(std::vector<World>& worlds);

// --shard I/N: worlds I, I + N, I + 2N, ... of the batch order (0 <= I < N).
struct Shard {
    int index = 0, count = 1;
    bool all() const { return count == 1; }
    std::string text() const;  // "I/N"
};
Shard parse_shard(const std::string& text);  // throws std::invalid_argument
std::vector<World> shard_worlds(const std::vector<World>& worlds, const Shard& shard);

// The content hash of a bake of `source_sha256` (the file's sha256) with
// `request`: sha256 of the core's version, the source's sha256 and every
// option that changes a file (not threads; the PNG-only options only when
// PNG is written). Recorded in the manifest as batch.content_hash.
std::string content_hash(const std::string& source_sha256, const BakeRequest& request);

// The manifest of the complete, intact bake in `dir`: every file it lists
// (`files`: size and sha256) is there with that size and sha256, and every
// output it names is among them; else nothing (no bake, a damaged or
// truncated one, an older manifest without `files`).
std::optional<nlohmann::json> intact_manifest(const std::filesystem::path& dir);

// One world's outcome.
struct Entry {
    World world;
    std::string status;  // "baked", "unchanged", "failed"
    std::string content_hash;  // empty when the source could not be hashed
    std::string error;
    double seconds = 0;
    bool preview = false;  // OUT/<name>/preview.png is there
    std::vector<std::string> warnings;  // the bake's manifest's (a black world, an option that does nothing ...)
};

// OUT/index.json (every world: name, source, dir, status, content_hash,
// error, warnings, seconds, preview; the counts; the shard) and OUT/index.html (a
// gallery of the preview sheets, failures first), each written to a
// temporary file and renamed. A shard of several writes
// OUT/index.<I>-of-<N>.json alone (a later run without --shard, where
// everything is unchanged, writes the whole index).
void write_index(const std::filesystem::path& out, const std::vector<Entry>& entries, const Shard& shard = {});

struct Options {
    int jobs = 1;         // worlds in flight at once
    bool force = false;   // bake even when the folder holds the same content hash
    LutCache* lut_cache = nullptr;
};

// What a run reports as it goes, from its worker threads (one call at a
// time: the run serialises them).
struct Events {
    std::function<void(size_t index, const World&)> started;
    std::function<void(size_t index, const std::string& stage, double fraction)> stage;
    std::function<void(size_t index, const Entry&)> finished;
    std::function<bool()> keep_going;  // false: cancel the bakes in flight, start no more
};

// Bakes each world into out/<name>/ (bake_file, with the plan made once
// from `request`, the preview sheet on, and batch.{content_hash, name} in the
// manifest), skipping those whose folder holds an intact bake of the same
// content hash unless `force`. A failed world is reported and the others go
// on. Returns one entry per world in the batch order (a cancelled run: the
// worlds finished). Throws std::runtime_error when `out` cannot be a batch's
// folder (a single bake's folder, a file).
std::vector<Entry> run_batch(const std::vector<World>& worlds, const std::filesystem::path& out,
                             const BakeRequest& request, const Options& options, const Events& events = {});

}  // namespace iblbake::batch
