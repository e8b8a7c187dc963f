#include "iblbake/pipeline/batch.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <exception>
#include <fstream>
#include <map>
#include <mutex>
#include <new>
#include <set>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "iblbake/io/hash.h"
#include "iblbake/io/open_regular.h"
#include "iblbake/io/text.h"
#include "iblbake/pipeline/bake_file.h"

#ifndef IBLBAKE_VERSION
#define IBLBAKE_VERSION "dev"
#endif

namespace iblbake::batch {

namespace fs = std::filesystem;
using nlohmann::json;

const std::vector<std::string>& image_extensions() {
    static const std::vector<std::string> kExt = {".exr", ".hdr", ".pic", ".png", ".jpg", ".jpeg", ".tif", ".tiff"};
    return kExt;
}

std::vector<std::string> read_list_file(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot read the list file " + io::printable(path));
    const fs::path base = fs::path(path).parent_path();
    std::vector<std::string> out;
    std::string line;
    while (std::getline(in, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const size_t first = line.find_first_not_of(" \t");
        if (first == std::string::npos || line[first] == '#') continue;
        line = line.substr(first, line.find_last_not_of(" \t") + 1 - first);
        const fs::path p(line);
        out.push_back(p.is_absolute() || base.empty() ? line : (base / p).string());
    }
    if (in.bad()) throw std::runtime_error("cannot read the list file " + io::printable(path));
    return out;
}

namespace {

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

bool has_extension(const fs::path& p, const std::vector<std::string>& extensions) {
    const std::string ext = lower(p.extension().string());
    return std::find(extensions.begin(), extensions.end(), ext) != extensions.end();
}

}  // namespace

std::vector<World> gather_worlds(const std::vector<std::string>& inputs, const std::vector<std::string>& extensions) {
    std::vector<World> worlds;
    std::set<std::string> seen;  // canonical paths
    auto add = [&](const std::string& source) {
        std::error_code ec;
        fs::path key = fs::weakly_canonical(fs::absolute(source, ec), ec);
        if (ec) key = fs::path(source).lexically_normal();
        if (seen.insert(key.string()).second) worlds.push_back({source, ""});
    };
    for (const std::string& input : inputs) {
        std::error_code ec;
        const fs::file_status st = fs::status(input, ec);
        if (fs::is_directory(st)) {
            std::vector<std::string> files;
            fs::directory_iterator it(input, ec), end;
            if (ec) throw std::runtime_error("cannot read the folder " + io::printable(input) + ": " + ec.message());
            for (; it != end; it.increment(ec)) {
                if (ec) throw std::runtime_error("cannot read the folder " + io::printable(input) + ": " + ec.message());
                const fs::path& p = it->path();
                if (p.filename().string()[0] == '.' || !has_extension(p, extensions)) continue;
                std::error_code e2;
                if (it->is_directory(e2)) continue;
                files.push_back(p.filename().string());
            }
            std::sort(files.begin(), files.end());
            for (const std::string& f : files) add((fs::path(input) / f).string());
        } else {
            add(input);  // a missing file, or one the reader refuses, fails as a world; the others go on
        }
    }
    name_worlds(worlds);
    return worlds;
}

std::string safe_name(const std::string& stem) {
    std::string s;
    for (char c : stem) {
        const unsigned char u = static_cast<unsigned char>(c);
        s += (std::isalnum(u) && u < 128) || c == '-' || c == '_' || c == '.' ? c : '_';
    }
    s.erase(0, s.find_first_not_of('.'));
    if (s.size() > 100) s.resize(100);
    while (!s.empty() && (s.back() == '.' || s.back() == ' ')) s.pop_back();
    return s.empty() ? "world" : s;
}

void name_worlds(std::vector<World>& worlds) {
    std::map<std::string, int> uses;  // lowercase safe name -> worlds that want it
    std::vector<std::string> wanted;
    for (const World& w : worlds) {
        wanted.push_back(safe_name(fs::path(w.source).stem().string()));
        ++uses[lower(wanted.back())];
    }
    for (size_t k = 0; k < worlds.size(); ++k) {
        std::string name = wanted[k];
        if (uses[lower(name)] > 1) {
            std::error_code ec;
            const std::string abs = fs::absolute(worlds[k].source, ec).lexically_normal().string();
            name += "-" + io::sha256_bytes(abs.data(), abs.size()).substr(0, 8);
        }
        worlds[k].name = name;
    }
}

std::string Shard::text() const { return std::to_string(index) + "/" + std::to_string(count); }

Shard parse_shard(const std::string& text) {
    const auto bad = [&] {
        return std::invalid_argument("--shard must be I/N with 0 <= I < N (e.g. 0/4), got '" + io::printable(text) +
                                     "'");
    };
    const auto number = [&](const std::string& part) {
        const bool digits = std::all_of(part.begin(), part.end(), [](char c) { return c >= '0' && c <= '9'; });
        if (part.empty() || part.size() > 6 || !digits) throw bad();
        return std::stoi(part);
    };
    const size_t slash = text.find('/');
    if (slash == std::string::npos) throw bad();
    const Shard s{number(text.substr(0, slash)), number(text.substr(slash + 1))};
    if (s.count < 1 || s.index >= s.count) throw bad();
    return s;
}

std::vector<World> shard_worlds(const std::vector<World>& worlds, const Shard& shard) {
    std::vector<World> out;
    for (size_t k = size_t(shard.index); k < worlds.size(); k += size_t(shard.count)) out.push_back(worlds[k]);
    return out;
}

std::string content_hash(const std::string& source_sha256, const BakeRequest& request) {
    json options = json::object();
    for (const OptionRow<BakeRequest>& row : option_table()) {
        const std::string& name = row.spec.name;
        if (name == "threads") continue;  // how fast, not what
        if (!request.write.png && (name == "png_encoding" || name == "exposure" || name == "rgbm_range")) continue;
        options[name] = option_value_text(row.get(request));
    }
    const std::string text = json{{"core", IBLBAKE_VERSION}, {"source_sha256", source_sha256}, {"options", options}}.dump();
    return io::sha256_bytes(text.data(), text.size());
}

namespace {

constexpr size_t kMaxManifest = io::kMaxManifestBytes;

// A name a manifest may list: a path inside the bake's folder (not absolute,
// no "..", no empty or "." parts).
bool inside(const std::string& name) {
    if (name.empty() || name.size() > 4096 || name[0] == '/' || name.find('\0') != std::string::npos) return false;
    for (const auto& part : fs::path(name))
        if (part.empty() || part == "." || part == "..") return false;
    return true;
}

}  // namespace

std::optional<json> intact_manifest(const fs::path& dir) {
    // Read only as a regular file, not through a link, and not without bound:
    // a FIFO named manifest.json would hang the batch, a device never end.
    const std::optional<std::string> text = io::read_regular_file((dir / "manifest.json").string(), kMaxManifest, false);
    if (!text) return std::nullopt;
    const json m = json::parse(*text, nullptr, false);
    if (!m.is_object() || !m.contains("files") || !m["files"].is_object() || m["files"].empty()) return std::nullopt;
    const json& files = m["files"];
    std::vector<std::string> listed;
    auto name_of = [&](const json& entry) {
        if (entry.is_object() && entry.contains("file") && entry["file"].is_string())
            listed.push_back(entry["file"].get<std::string>());
    };
    if (m.contains("specular") && m["specular"].is_array())
        for (const json& e : m["specular"]) name_of(e);
    for (const char* key : {"irradiance", "brdf_lut"})
        if (m.contains(key)) name_of(m[key]);
    if (m.contains("presets") && m["presets"].is_object())
        for (const auto& [name, p] : m["presets"].items()) {
            if (!p.is_object() || !p.contains("files") || !p["files"].is_object()) continue;
            const std::string sub = p.contains("dir") && p["dir"].is_string() ? p["dir"].get<std::string>() : "";
            for (const auto& [role, f] : p["files"].items())
                if (f.is_string()) listed.push_back(sub.empty() ? f.get<std::string>() : sub + "/" + f.get<std::string>());
        }
    for (const std::string& f : listed)
        if (!files.contains(f)) return std::nullopt;
    for (const auto& [name, entry] : files.items()) {
        if (!inside(name)) return std::nullopt;  // a file outside the folder: not a bake this wrote
        try {
            const fs::path p = dir / name;
            std::error_code ec;
            if (!entry.is_object() || fs::file_size(p, ec) != entry.at("bytes").get<uintmax_t>() || ec ||
                io::sha256_file(p.string()) != entry.at("sha256").get<std::string>())
                return std::nullopt;
        } catch (const std::exception&) {
            return std::nullopt;
        }
    }
    return std::optional<json>(std::in_place, m);  // not `return m;`: GCC 16 finds it ambiguous (json's own conversions)
}

namespace {

std::string html_escape(const std::string& s) {
    std::string out;
    for (char c : s) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            case '\'': out += "&#39;"; break;
            default: out += c;
        }
    }
    return out;
}

// Written to a new file beside `path` (created here, never one found there:
// not through a link, not into a FIFO) and renamed over it.
void write_atomically(const fs::path& path, const std::string& text) {
    const fs::path tmp = path.string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                         std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id()));
    std::error_code ec;
    fs::remove(tmp, ec);  // one left by a killed run of this process number
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    bool ok = fd >= 0;
    for (size_t done = 0; ok && done < text.size();) {
        const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        ok = n > 0;
        done += ok ? size_t(n) : 0;
    }
    if (fd >= 0 && ::close(fd) != 0) ok = false;
    if (ok) fs::rename(tmp, path, ec);
    if (!ok || ec) {
        fs::remove(tmp, ec);
        throw std::runtime_error("cannot write " + io::printable(path.string()));
    }
}

std::string gallery(const std::vector<Entry>& entries, const json& counts) {
    std::ostringstream h;
    h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>iblbake: " << entries.size()
      << " worlds</title>\n<style>\n"
         "body{font-family:sans-serif;background:#1e1e1e;color:#ddd;margin:16px}\n"
         "h1{font-size:18px;font-weight:normal}\n"
         ".grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(260px,1fr));gap:12px}\n"
         ".w{background:#2a2a2a;border-radius:4px;padding:8px;font-size:12px;overflow-wrap:anywhere}\n"
         ".w img{width:100%;display:block;background:#000}\n"
         ".w b{font-size:13px;color:#fff}\n"
         ".failed{background:#4a1d1d}.failed .err{color:#ff9a9a;white-space:pre-wrap}\n"
         ".warn{color:#e8c66a}\n"
         ".unchanged .st{color:#9ac}.baked .st{color:#9c9}\n"
         "</style></head><body>\n<h1>iblbake: "
      << entries.size() << " worlds: " << counts.value("baked", 0) << " baked, " << counts.value("unchanged", 0)
      << " unchanged, " << counts.value("failed", 0) << " failed</h1>\n<div class=\"grid\">\n";
    std::vector<const Entry*> order;
    for (const Entry& e : entries) order.push_back(&e);
    std::stable_partition(order.begin(), order.end(), [](const Entry* e) { return e->status == "failed"; });
    for (const Entry* e : order) {
        const std::string name = html_escape(e->world.name);
        h << "<div class=\"w " << e->status << "\">";
        if (e->preview)
            h << "<a href=\"" << name << "/preview.png\"><img loading=\"lazy\" src=\"" << name
              << "/preview.png\" alt=\"" << name << "\"></a>";
        h << "<b>" << name << "</b> <span class=\"st\">" << e->status << "</span><br>"
          << html_escape(io::printable(e->world.source));
        if (!e->content_hash.empty()) h << "<br>hash " << e->content_hash.substr(0, 12);
        if (e->status == "baked") {
            char buf[32];
            std::snprintf(buf, sizeof buf, "%.2f s", e->seconds);
            h << " &middot; " << buf;
        }
        if (!e->error.empty()) h << "<div class=\"err\">" << html_escape(io::printable(e->error)) << "</div>";
        for (const std::string& w : e->warnings) h << "<div class=\"warn\">" << html_escape(io::printable(w)) << "</div>";
        h << "</div>\n";
    }
    h << "</div>\n</body></html>\n";
    return h.str();
}

}  // namespace

namespace {

json printable_all(const std::vector<std::string>& texts) {
    json out = json::array();
    for (const std::string& t : texts) out.push_back(io::printable(t));
    return out;
}

}  // namespace

void write_index(const fs::path& out, const std::vector<Entry>& entries, const Shard& shard) {
    json worlds = json::array();
    json counts = {{"baked", 0}, {"unchanged", 0}, {"failed", 0}};
    for (const Entry& e : entries) {
        counts[e.status] = counts.value(e.status, 0) + 1;
        worlds.push_back({{"name", e.world.name},
                          {"source", io::printable(e.world.source)},
                          {"dir", e.world.name},
                          {"status", e.status},
                          {"content_hash", e.content_hash.empty() ? json(nullptr) : json(e.content_hash)},
                          {"error", e.error.empty() ? json(nullptr) : json(io::printable(e.error))},
                          {"warnings", printable_all(e.warnings)},
                          {"seconds", e.seconds},
                          {"preview", e.preview ? json(e.world.name + "/preview.png") : json(nullptr)}});
    }
    const json index = {{"generator", "iblbake " IBLBAKE_VERSION},
                        {"shard", shard.all() ? json(nullptr) : json(shard.text())},
                        {"counts", counts},
                        {"worlds", worlds}};
    if (!shard.all()) {
        write_atomically(out / ("index." + std::to_string(shard.index) + "-of-" + std::to_string(shard.count) + ".json"),
                         index.dump(2) + "\n");
        return;
    }
    write_atomically(out / "index.json", index.dump(2) + "\n");
    write_atomically(out / "index.html", gallery(entries, counts));
}

namespace {

std::string message_of(const std::exception_ptr& error) {
    try {
        std::rethrow_exception(error);
    } catch (const std::bad_alloc&) {
        return "out of memory (try a smaller --face-size or source)";
    } catch (const std::exception& e) {
        std::string msg = e.what();
        const std::string fs_prefix = "filesystem error: ";
        if (msg.rfind(fs_prefix, 0) == 0) msg = "file system: " + msg.substr(fs_prefix.size());
        return msg;
    } catch (...) {
        return "unknown error";
    }
}

}  // namespace

std::vector<Entry> run_batch(const std::vector<World>& worlds, const fs::path& out, const BakeRequest& request,
                             const Options& options, const Events& events) {
    std::error_code ec;
    if (fs::exists(out / "manifest.json", ec))
        throw std::runtime_error(io::printable(out.string()) +
                                 " holds a single bake (manifest.json): a batch writes one folder per world into "
                                 "a folder of its own");
    fs::create_directories(out, ec);
    if (!fs::is_directory(out, ec))
        throw std::runtime_error("cannot make the batch's folder " + io::printable(out.string()) +
                                 (ec ? ": " + ec.message() : ""));
    BakeRequest with_preview = request;
    with_preview.write.preview = true;  // the gallery shows each world's preview sheet
    const BakePlan plan = make_plan(with_preview.bake, with_preview.write);

    std::vector<std::optional<Entry>> results(worlds.size());
    std::atomic<size_t> next{0};
    std::atomic<bool> stopping{false};
    std::mutex report;  // one event at a time
    auto keep_going = [&] {
        if (stopping) return false;
        if (events.keep_going) {
            std::lock_guard<std::mutex> lock(report);
            if (!events.keep_going()) stopping = true;
        }
        return !stopping;
    };
    auto bake_one = [&](size_t k) {
        const World& w = worlds[k];
        Entry e{w, "failed", "", "", 0.0, false, {}};
        const fs::path dir = out / w.name;
        std::error_code ec;
        const auto start = std::chrono::steady_clock::now();
        auto stage = [&](const std::string& s, double f) {
            if (!events.stage) return;
            std::lock_guard<std::mutex> lock(report);
            events.stage(k, s, f);
        };
        try {
            stage("hashing", 0.0);
            if (!fs::is_regular_file(w.source, ec))
                throw std::runtime_error(fs::exists(w.source, ec) ? "not a regular file: " + io::printable(w.source)
                                                                  : "no such file: " + io::printable(w.source));
            // Its stamp goes with it: bake_file gives the manifest this digest
            // rather than hashing the file again, while the file keeps it.
            const io::FileDigest digest = io::sha256_file_stamped(w.source);
            e.content_hash = content_hash(digest.sha256, with_preview);
            stage("checking", 0.0);
            const std::optional<json> old = options.force ? std::nullopt : intact_manifest(dir);
            json m;
            if (old && old->contains("batch") && (*old)["batch"].value("content_hash", "") == e.content_hash) {
                e.status = "unchanged";
                m = *old;
            } else {
                BakePlan p = plan;
                p.write.manifest_extra["batch"] = {{"content_hash", e.content_hash}, {"name", w.name}};
                stage("reading", 0.0);
                m = bake_file(w.source, dir, p,
                          [&](const std::string& s, double f) {
                              stage(s, f);
                              return keep_going();
                          },
                          options.lut_cache, &digest);
                e.status = "baked";
            }
            if (m.contains("warnings") && m["warnings"].is_array())
                for (const json& t : m["warnings"])
                    if (t.is_string()) e.warnings.push_back(t.get<std::string>());
            e.preview = fs::is_regular_file(dir / "preview.png", ec);
        } catch (const Cancelled&) {
            return;  // not finished: not in the index
        } catch (...) {
            e.status = "failed";
            e.error = message_of(std::current_exception());
        }
        e.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (events.finished) {
            std::lock_guard<std::mutex> lock(report);
            events.finished(k, e);
        }
        results[k] = std::move(e);
    };
    auto worker = [&] {
        for (;;) {
            if (!keep_going()) return;
            const size_t k = next++;
            if (k >= worlds.size()) return;
            if (events.started) {
                std::lock_guard<std::mutex> lock(report);
                events.started(k, worlds[k]);
            }
            bake_one(k);
        }
    };
    const int jobs = std::max(1, std::min<int>(options.jobs, int(worlds.size())));
    std::vector<std::thread> threads;
    for (int j = 1; j < jobs; ++j) threads.emplace_back(worker);
    worker();
    for (std::thread& t : threads) t.join();
    std::vector<Entry> entries;
    for (auto& r : results)
        if (r) entries.push_back(std::move(*r));
    return entries;
}

}  // namespace iblbake::batch
