// iblbake bake A.exr B.hdr DIR/ ... -o OUT: the CLI's side of a batch
// (pipeline/batch.h runs it): its own arguments (--list, --jobs, --shard,
// --force: arguments of the run, not options of a bake, so they are not in
// the option table), the progress bar or plain lines, the summary, the exit
// code. main.cpp registers the arguments and hands a batch over.
#pragma once
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "iblbake/bake/lut_cache.h"
#include "iblbake/pipeline/options.h"

namespace iblbake::cli {

struct BatchArgs {
    std::vector<std::string> lists;  // --list FILE (repeatable)
    int jobs = 1;
    std::string shard;  // "I/N"
    bool force = false;
};

void add_batch_args(CLI::App* bake, BatchArgs& args);

// A batch: several sources, a folder, or a list file. One file without
// them is today's single bake into OUT itself (then the batch's own
// arguments are refused: throws std::invalid_argument).
bool is_batch(const std::vector<std::string>& sources, const BatchArgs& args);

// Runs the batch and returns the exit code: 0 when every world was baked or
// unchanged, 1 when any failed (after baking the others), 128 + N after
// signal N.
int run_batch(const std::vector<std::string>& sources, const std::string& outdir, const BakeRequest& request,
              const BatchArgs& args, LutCache* lut_cache, bool quiet);

}  // namespace iblbake::cli
