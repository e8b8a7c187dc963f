#include "batch.h"

#include <sys/ioctl.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "iblbake/io/text.h"
#include "iblbake/pipeline/batch.h"

namespace iblbake::cli {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::atomic<int> g_batch_signal{0};
extern "C" void batch_stop(int sig) { g_batch_signal = sig; }

std::string clock_text(double seconds) {
    if (!(seconds >= 0) || seconds > 360000) return "--:--";
    const long s = long(seconds + 0.5);
    char buf[32];
    if (s >= 3600) std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
    else std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
    return buf;
}

// What the run shows: a bar redrawn in place on a terminal (stderr), else
// one line per world on stdout.
class Display {
public:
    Display(size_t total, bool tty, bool quiet) : total_(total), tty_(tty && !quiet), quiet_(quiet) {
        if (tty_) ticker_ = std::thread([this] { tick(); });
    }
    ~Display() { close(); }
    void close() {
        {
            std::lock_guard<std::mutex> lock(m_);
            if (closed_) return;
            closed_ = true;
        }
        cv_.notify_all();
        if (ticker_.joinable()) ticker_.join();
        if (tty_) std::fprintf(stderr, "\r\033[K");
        std::fflush(stderr);
    }
    void started(const batch::World& w) {
        std::lock_guard<std::mutex> lock(m_);
        current_ = w.name;
        stage_ = "starting";
        fraction_ = 0;
        draw_locked();
    }
    void stage(const batch::World& w, const std::string& stage, double fraction) {
        std::lock_guard<std::mutex> lock(m_);
        current_ = w.name;
        stage_ = stage;
        fraction_ = fraction;
    }
    void finished(const batch::Entry& e) {
        std::lock_guard<std::mutex> lock(m_);
        ++done_;
        if (e.status != "unchanged") ++worked_;
        if (quiet_) return;
        char secs[32];
        std::snprintf(secs, sizeof secs, "%.2f s", e.seconds);
        std::string line = "[" + std::to_string(done_) + "/" + std::to_string(total_) + "] " + e.status + " " +
                           io::printable(e.world.name) + (e.status == "baked" ? std::string(" in ") + secs : "") +
                           (e.error.empty() ? "" : ": " + io::printable(e.error));
        if (tty_) {
            if (e.status == "failed") std::fprintf(stderr, "\r\033[K%s\n", line.c_str());
        } else {
            std::printf("%s\n", line.c_str());
            std::fflush(stdout);
        }
        // A new bake's warnings (a black world ...), on stderr as a single bake's are.
        if (e.status == "baked")
            for (const std::string& w : e.warnings)
                std::fprintf(stderr, "%siblbake: warning: %s: %s\n", tty_ ? "\r\033[K" : "",
                             io::printable(e.world.name).c_str(), io::printable(w).c_str());
        if (tty_) draw_locked();
    }

private:
    void tick() {
        std::unique_lock<std::mutex> lock(m_);
        while (!closed_) {
            draw_locked();
            cv_.wait_for(lock, std::chrono::milliseconds(250));
        }
    }
    // [#####.....] 12/50 forest: specular 40% | 3.1 worlds/min | ETA 2:05
    void draw_locked() {
        if (!tty_ || closed_) return;
        const double elapsed = std::chrono::duration<double>(Clock::now() - start_).count();
        const int width = 24;
        const int filled = total_ ? int(width * double(done_) / double(total_)) : width;
        std::string bar = "[" + std::string(size_t(filled), '#') + std::string(size_t(width - filled), '.') + "]";
        char rate[64] = "";
        char eta[64] = "ETA --:--";
        if (done_ > 0 && elapsed > 0) {
            std::snprintf(rate, sizeof rate, " | %.1f worlds/min", 60.0 * double(done_) / elapsed);
            std::snprintf(eta, sizeof eta, "ETA %s", clock_text(elapsed / double(done_) * double(total_ - done_)).c_str());
        }
        std::string now;
        if (!current_.empty() && done_ < total_) {
            char pct[16];
            std::snprintf(pct, sizeof pct, " %d%%", int(fraction_ * 100 + 0.5));
            now = " " + io::printable(current_) + ": " + stage_ + (fraction_ > 0 && stage_ != "writing" ? pct : "");
        }
        std::string line = bar + " " + std::to_string(done_) + "/" + std::to_string(total_) + now + rate + " | " + eta +
                           " | " + clock_text(elapsed);
        struct winsize ws {};
        const size_t cols = ::ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 10 ? ws.ws_col : 100;
        if (line.size() > cols - 1) line.resize(cols - 1);
        std::fprintf(stderr, "\r%s\033[K", line.c_str());
        std::fflush(stderr);
    }

    size_t total_;
    bool tty_, quiet_;
    std::mutex m_;
    std::condition_variable cv_;
    bool closed_ = false;
    std::thread ticker_;
    const Clock::time_point start_ = Clock::now();
    size_t done_ = 0, worked_ = 0;
    std::string current_, stage_;
    double fraction_ = 0;
};

}  // namespace

void add_batch_args(CLI::App* bake, BatchArgs& args) {
    bake->add_option("--list", args.lists,
                     "batch: a file naming sources, one a line ('#' comments; relative to the file's folder); "
                     "repeatable")
        ->type_name("FILE");
    bake->add_option("--jobs", args.jobs, "batch: worlds in flight at once (overlaps one's reading with another's "
                                          "writing; each bake already uses every core)")
        ->check(CLI::Range(1, 64))
        ->capture_default_str();
    bake->add_option("--shard", args.shard, "batch: bake worlds I, I+N, I+2N, ... of the batch (0 <= I < N), for a farm")
        ->type_name("I/N");
    bake->add_flag("--force", args.force, "batch: bake worlds whose folder already holds the same content hash");
}

bool is_batch(const std::vector<std::string>& sources, const BatchArgs& args) {
    std::error_code ec;
    const bool batch = sources.size() != 1 || !args.lists.empty() || fs::is_directory(sources.front(), ec);
    if (!batch && (args.jobs != 1 || !args.shard.empty() || args.force))
        throw std::invalid_argument(
            "--jobs, --shard and --force apply to a batch (several sources, a folder or --list); one file is "
            "baked into the output folder itself");
    return batch;
}

int run_batch(const std::vector<std::string>& sources, const std::string& outdir, const BakeRequest& request,
              const BatchArgs& args, LutCache* lut_cache, bool quiet) {
    const auto started = Clock::now();
    const batch::Shard shard = args.shard.empty() ? batch::Shard{} : batch::parse_shard(args.shard);
    std::vector<std::string> inputs = sources;
    for (const std::string& list : args.lists) {
        const std::vector<std::string> more = batch::read_list_file(list);
        inputs.insert(inputs.end(), more.begin(), more.end());
    }
    if (inputs.empty()) throw std::invalid_argument("no sources: name files or folders, or give --list FILE");
    const std::vector<batch::World> all = batch::gather_worlds(inputs);
    if (all.empty()) {
        std::string extensions;
        for (const std::string& x : batch::image_extensions()) extensions += (extensions.empty() ? "" : " ") + x;
        throw std::invalid_argument("no worlds to bake: the folders given hold no image files (" + extensions + ")");
    }
    const std::vector<batch::World> worlds = batch::shard_worlds(all, shard);

    struct sigaction sa {};
    sa.sa_handler = batch_stop;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);

    const bool tty = ::isatty(STDERR_FILENO) == 1;
    if (!quiet) {
        const std::string of_shard =
            shard.all() ? "" : " (shard " + shard.text() + " of " + std::to_string(all.size()) + ")";
        const std::string at_once = args.jobs > 1 ? ", " + std::to_string(args.jobs) + " at once" : "";
        std::printf("batch: %zu worlds%s -> %s%s\n", worlds.size(), of_shard.c_str(), io::printable(outdir).c_str(),
                    at_once.c_str());
    }
    std::fflush(stdout);
    Display display(worlds.size(), tty, quiet);
    batch::Events events;
    events.started = [&](size_t, const batch::World& w) { display.started(w); };
    events.stage = [&](size_t k, const std::string& s, double f) { display.stage(worlds[k], s, f); };
    events.finished = [&](size_t, const batch::Entry& e) { display.finished(e); };
    events.keep_going = [] { return g_batch_signal == 0; };
    batch::Options options;
    options.jobs = args.jobs;
    options.force = args.force;
    options.lut_cache = lut_cache;
    const std::vector<batch::Entry> entries = batch::run_batch(worlds, outdir, request, options, events);
    display.close();
    batch::write_index(outdir, entries, shard);

    size_t baked = 0, unchanged = 0, failed = 0;
    for (const batch::Entry& e : entries) {
        if (e.status == "baked") ++baked;
        else if (e.status == "unchanged") ++unchanged;
        else ++failed;
    }
    const double wall = std::chrono::duration<double>(Clock::now() - started).count();
    const fs::path index = fs::path(outdir) / (shard.all() ? "index.html"
                                                           : "index." + std::to_string(shard.index) + "-of-" +
                                                                 std::to_string(shard.count) + ".json");
    if (!quiet)
        std::printf("batch: %zu baked, %zu unchanged, %zu failed of %zu worlds in %.1f s; %s\n", baked, unchanged,
                    failed, worlds.size(), wall, io::printable(index.string()).c_str());
    std::fflush(stdout);
    for (const batch::Entry& e : entries)
        if (e.status == "failed")
            std::cerr << "iblbake: error: " << io::printable(e.world.name) << ": " << io::printable(e.error) << "\n";
    if (const int sig = g_batch_signal) {
        std::cerr << "iblbake: error: batch stopped (" << strsignal(sig) << ") after " << entries.size() << " of "
                  << worlds.size() << " worlds; run the same command again to go on\n";
        return 128 + sig;
    }
    return failed ? 1 : 0;
}

}  // namespace iblbake::cli
