#include "iblbake/io/output_dir.h"

#include <fcntl.h>
#include <stdio.h>
#include <sys/file.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <chrono>
#include <cstdlib>
#include <random>
#include <regex>
#include <set>
#include <stdexcept>
#include <string>
#include <system_error>
#include <typeinfo>

#include <nlohmann/json.hpp>

#include "iblbake/io/open_regular.h"
#include "iblbake/io/text.h"

namespace iblbake::io {

namespace fs = std::filesystem;

namespace {
std::string random_suffix() {
    std::random_device rd;
    const char* digits = "0123456789abcdef";
    std::string s;
    for (int i = 0; i < 8; ++i) s += digits[rd() % 16];
    return s;
}

bool renameat2(const fs::path& a, const fs::path& b, unsigned flags) {
#ifdef SYS_renameat2
    return syscall(SYS_renameat2, AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), flags) == 0;
#else
    (void)a; (void)b; (void)flags;
    errno = ENOSYS;
    return false;
#endif
}
bool exchange(const fs::path& a, const fs::path& b) { return renameat2(a, b, 2); }  // RENAME_EXCHANGE
bool rename_noreplace(const fs::path& a, const fs::path& b) { return renameat2(a, b, 1); }  // RENAME_NOREPLACE
}  // namespace

namespace {
fs::path normalised(const fs::path& p) {
    if (p.empty()) throw std::runtime_error("the output folder must be a non-empty path");
    fs::path a = fs::weakly_canonical(fs::absolute(p));
    if (a.filename().empty()) a = a.parent_path();  // "out/" -> "out"
    return a;
}

bool is_within(const fs::path& inner, const fs::path& outer) {  // inner == outer or below it
    auto i = inner.begin(), o = outer.begin();
    for (; o != outer.end(); ++o, ++i)
        if (i == inner.end() || *i != *o) return false;
    return true;
}

std::string quoted(const fs::path& p) { return "'" + printable(p.string()) + "'"; }

// A bake's manifest.json: only a regular file, not through a link (a FIFO
// named so would hang the bake, a device never end), at most
// kMaxManifestBytes; "" otherwise (not a bake's).
std::string read_manifest(const fs::path& dir) {
    return read_regular_file((dir / "manifest.json").string(), kMaxManifestBytes, false).value_or("");
}

bool holds_a_bake(const fs::path& dir) {
    return read_manifest(dir).find("\"generator\": \"iblbake\"") != std::string::npos;
}

// What an earlier bake in `dir` wrote: the manifest's `files` (every file,
// with its size and sha256) and `encodings`, its listed outputs, and any name
// iblbake writes (for a manifest too damaged to parse).
bool written_by_a_bake(const std::string& rel, const std::set<std::string>& listed) {
    static const std::regex kOwn(R"((manifest\.json|preview\.png|(irradiance|brdf_lut|specular_[0-9]+)\.(exr|png)))");
    return listed.count(rel) || std::regex_match(rel, kOwn);
}

std::set<std::string> files_of_manifest(const fs::path& dir) {
    std::set<std::string> out;
    const nlohmann::json m = nlohmann::json::parse(read_manifest(dir), nullptr, false);
    if (!m.is_object()) return out;
    for (const char* key : {"files", "encodings"})
        if (m.contains(key) && m[key].is_object())
            for (const auto& [name, v] : m[key].items()) out.insert(name);
    for (const char* key : {"irradiance", "brdf_lut"})
        if (m.contains(key) && m[key].is_object() && m[key].contains("file") && m[key]["file"].is_string())
            out.insert(m[key]["file"].get<std::string>());
    if (m.contains("specular") && m["specular"].is_array())
        for (const auto& e : m["specular"])
            if (e.is_object() && e.contains("file") && e["file"].is_string()) out.insert(e["file"].get<std::string>());
    // Engine presets' folders (a manifest written before `files` was kept).
    if (m.contains("presets") && m["presets"].is_object())
        for (const auto& [name, e] : m["presets"].items()) {
            if (!e.is_object() || !e.contains("dir") || !e["dir"].is_string() || !e.contains("files") ||
                !e["files"].is_object())
                continue;
            for (const auto& [role, f] : e["files"].items())
                if (f.is_string()) out.insert((fs::path(e["dir"].get<std::string>()) / f.get<std::string>()).generic_string());
        }
    return out;
}

// Files in a bake folder that its bake did not write (a user's notes, ...):
// replacing the folder would delete them.
std::vector<std::string> foreign_files(const fs::path& dir) {
    const std::set<std::string> listed = files_of_manifest(dir);
    std::vector<std::string> out;
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec)) {
        if (it->is_directory(ec)) continue;
        const std::string rel = fs::relative(it->path(), dir, ec).generic_string();
        if (!written_by_a_bake(rel, listed)) out.push_back(rel);
    }
    return out;
}

std::string names_of(const std::vector<std::string>& v) {
    std::string names;
    for (size_t i = 0; i < v.size() && i < 3; ++i) names += (i ? ", '" : "'") + printable(v[i]) + "'";
    if (v.size() > 3) names += " and " + std::to_string(v.size() - 3) + " more";
    return names;
}

// Why the folder `dir` may not be replaced by a bake, as the end of a
// sentence that starts with its name ("" when it may: it is empty, or holds
// an earlier bake and nothing else).
std::string why_kept(const fs::path& dir) {
    std::error_code ec;
    if (fs::is_empty(dir, ec) && !ec) return "";
    if (!holds_a_bake(dir))
        return " exists and holds something other than an iblbake bake (no iblbake manifest.json)";
    const std::vector<std::string> foreign = foreign_files(dir);
    if (!foreign.empty()) return " holds " + names_of(foreign) + ", which its earlier bake did not write";
    return "";
}

// Staging names: .NAME.iblbake-PID-XXXXXXXX, NAME cut to 200 bytes so that a
// legal 255-byte folder name still leaves room for the tag.
const char* kStagingTag = ".iblbake-";
constexpr size_t kStagingNameMax = 200;

std::string staging_prefix(const fs::path& destination) {
    return "." + destination.filename().string().substr(0, kStagingNameMax) + kStagingTag;
}

// A staging folder's lock: held (flock) by its bake from creation to the
// end. Another PID namespace (a container sharing the folder) sees other
// process numbers, but the same locks.
int lock_folder(const fs::path& dir) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return -1;
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
        ::close(fd);
        return -1;
    }
    return fd;
}

bool lock_is_held(const fs::path& dir) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return false;
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
    ::close(fd);
    return held;
}

// Staging folders (and swapped-out earlier bakes) of bakes that were killed,
// whatever folder they were for: removed when no bake holds their lock and
// their process no longer exists here (or they are more than a day old: the
// number was taken by another process since).
void remove_stale_staging(const fs::path& parent) {
    static const std::regex kStaging(R"(\..*\.iblbake-([0-9]+)-[0-9a-f]{8})");
    std::error_code ec;
    std::vector<fs::path> stale;
    for (auto it = fs::directory_iterator(parent, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
        const std::string name = it->path().filename().string();
        std::smatch m;
        if (!std::regex_match(name, m, kStaging)) continue;
        const long pid = std::strtol(m[1].str().c_str(), nullptr, 10);
        std::error_code e2;
        if (pid <= 0 || pid == ::getpid() || lock_is_held(it->path())) continue;
        const bool gone = !fs::exists("/proc/" + std::to_string(pid), e2) && !e2;
        const auto age = fs::file_time_type::clock::now() - fs::last_write_time(it->path(), e2);
        if (gone || (!e2 && age > std::chrono::hours(24))) stale.push_back(it->path());
    }
    for (const fs::path& p : stale) fs::remove_all(p, ec);
}
}  // namespace

std::string outside_staging(const std::string& text) {
    static const std::regex kStagingName(R"(/\.([^/']{1,200})\.iblbake-[0-9]+-[0-9a-f]{8}(?=/|'|$))");
    return std::regex_replace(text, kStagingName, "/$1");
}

void rethrow_outside_staging(const std::exception_ptr& error) {
    try {
        std::rethrow_exception(error);
    } catch (const std::runtime_error& e) {
        if (typeid(e) != typeid(std::runtime_error)) throw;  // Cancelled and other kinds pass unchanged
        const std::string shown = outside_staging(e.what());
        if (shown == e.what()) throw;
        throw std::runtime_error(shown);
    }
}

void check_replaceable(const fs::path& destination, const fs::path& keep) {
    std::error_code ec;
    // A dangling symbolic link: the bake would replace the link, not fill its target.
    const fs::path raw = destination.empty() ? destination : fs::absolute(destination, ec);
    if (!raw.empty() && fs::is_symlink(fs::symlink_status(raw, ec)) && !fs::exists(raw, ec))
        throw std::runtime_error("output " + quoted(raw) + " is a symbolic link to " +
                                 quoted(fs::read_symlink(raw, ec)) +
                                 ", which does not exist; remove the link or create its target");
    for (const fs::path& part : destination)
        if (part.native().size() > 255)
            throw std::runtime_error("output " + quoted(destination) + ": the name " + quoted(fs::path(part.native().substr(0, 24) + "...")) +
                                     " is " + std::to_string(part.native().size()) +
                                     " bytes long; file systems allow 255");
    const fs::path dest = normalised(destination);
    if (dest == dest.root_path()) throw std::runtime_error("refusing to write a bake over '/'");
    if (is_within(fs::current_path(ec), dest))
        throw std::runtime_error("output folder " + quoted(dest) + " is the current folder or holds it");
    if (!keep.empty() && is_within(fs::weakly_canonical(fs::absolute(keep)), dest))
        throw std::runtime_error("output folder " + quoted(dest) + " holds the source image " + quoted(keep) +
                                 "; choose another folder");
    // The nearest existing folder above must take the staging folder.
    fs::path parent = dest.parent_path();
    while (!parent.empty() && parent != parent.root_path() && !fs::exists(parent, ec)) parent = parent.parent_path();
    if (fs::exists(parent, ec) && ::access(parent.c_str(), W_OK | X_OK) != 0)
        throw std::runtime_error("cannot write into " + quoted(parent) + ": " + std::strerror(errno));
    const fs::file_status st = fs::status(dest, ec);
    if (st.type() == fs::file_type::not_found) return;
    if (ec) throw std::runtime_error("cannot use output " + quoted(dest) + ": " + ec.message());
    if (st.type() != fs::file_type::directory)
        throw std::runtime_error("output " + quoted(dest) + " exists and is not a folder");
    if (fs::is_empty(dest, ec) && !ec) return;
    const std::string why = why_kept(dest);
    if (!why.empty())
        throw std::runtime_error("output folder " + quoted(dest) + why +
                                 "; refusing to replace it: move it away or choose another folder");
    // Replacing the folder removes the earlier bake's files: a read-only
    // folder would be swapped out and then left behind, undeletable.
    if (::access(dest.c_str(), W_OK | X_OK) != 0)
        throw std::runtime_error("output folder " + quoted(dest) + " is read-only (" + std::strerror(errno) +
                                 "): its earlier bake could not be removed; make it writable or choose another folder");
}

StagingDir::StagingDir(const fs::path& destination) : destination_(normalised(destination)) {
    check_replaceable(destination);
    const fs::path parent = destination_.parent_path();
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) throw std::runtime_error("cannot create " + quoted(parent) + ": " + ec.message());
    remove_stale_staging(parent);
    staging_ = parent / (staging_prefix(destination_) + std::to_string(::getpid()) + "-" + random_suffix());
    if (!fs::create_directory(staging_, ec) || ec)
        throw std::runtime_error("cannot create " + quoted(staging_) + ": " + ec.message());
    lock_ = lock_folder(staging_);
}

StagingDir::~StagingDir() {
    if (!committed_) {
        std::error_code ec;
        fs::remove_all(staging_, ec);
    }
    if (lock_ >= 0) ::close(lock_);
}

void StagingDir::commit() {
    std::error_code ec;
    const auto changed = [&](const std::string& why) {
        throw std::runtime_error("output folder " + quoted(destination_) + why +
                                 " (added during the bake); it was left as it was and this bake was not written: "
                                 "move the files away and bake again");
    };
    // A folder made at the destination during the bake is never replaced
    // unseen: where it is not there, the bake is moved in only if it still is not.
    if (!fs::exists(destination_, ec) && !fs::is_symlink(fs::symlink_status(destination_, ec)) &&
        rename_noreplace(staging_, destination_)) {
        committed_ = true;
        return;
    }
    if (fs::exists(destination_, ec)) {
        if (exchange(staging_, destination_)) {
            // staging_ now names what was at the destination: checked again,
            // since files may have been added to it while the bake ran.
            const std::string why = why_kept(staging_);
            if (!why.empty()) {
                if (!exchange(staging_, destination_)) {  // put it back
                    committed_ = true;  // never removed: the user's files are there
                    throw std::runtime_error("output folder " + quoted(destination_) + " changed during the bake (it" +
                                             why + "): it is now at " + quoted(staging_));
                }
                changed(why);
            }
            fs::remove_all(staging_, ec);
        } else {
            const std::string why = why_kept(destination_);
            if (!why.empty()) changed(why);
            // Named like a staging folder, so a kill here leaves nothing the next bake won't clean.
            const fs::path old = destination_.parent_path() /
                                 (staging_prefix(destination_) + std::to_string(::getpid()) + "-" + random_suffix());
            fs::rename(destination_, old, ec);
            if (ec) throw std::runtime_error("cannot move the earlier bake out of " + quoted(destination_) + ": " + ec.message());
            fs::rename(staging_, destination_, ec);
            if (ec) {  // put the earlier bake back
                std::error_code ec2;
                fs::rename(old, destination_, ec2);
                throw std::runtime_error("cannot move the bake into " + quoted(destination_) + ": " + ec.message());
            }
            fs::remove_all(old, ec);
        }
    } else {
        fs::rename(staging_, destination_, ec);
        if (ec) throw std::runtime_error("cannot move the bake into " + quoted(destination_) + ": " + ec.message());
    }
    committed_ = true;
}

}  // namespace iblbake::io
