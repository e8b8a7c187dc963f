// A file in, a folder out: read (io), hash, compute, write, as the plan
// says. Shared by the CLI and the Python module so both behave the same.
#pragma once
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "iblbake/bake/bake.h"
#include "iblbake/bake/lut_cache.h"
#include "iblbake/io/hash.h"
#include "iblbake/pipeline/plan.h"

namespace iblbake {

// Any failure (unreadable source, bad options, strict bad input, write error,
// cancel) throws before the output folder is touched. Returns the manifest.
// `hashed`: the source's sha256 as the caller already took it (a library
// run's content hash), given to the manifest when the file has kept the
// stamp it had then both before and after it is decoded; else, and without
// it, the file is hashed here.
nlohmann::json bake_file(const std::string& source_path, const std::filesystem::path& outdir, const BakePlan& plan,
                         const ProgressFn& progress = {}, LutCache* lut_cache = nullptr,
                         const io::FileDigest* hashed = nullptr);

}  // namespace iblbake
