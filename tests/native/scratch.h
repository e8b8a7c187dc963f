// Where a native test writes its files: one folder per test process under
// the system's temporary folder, removed when the process exits. ctest runs
// each test in a process of its own (gtest_discover_tests), so a test's
// files go when it ends, passed or failed, where folders named after the
// process id stayed behind, run after run (a CI host's /tmp had 260 MB of
// them). A test that crashes leaves its folder, to be looked at.
#pragma once
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace iblbake::scratch {

// This process's folder, made on first use.
inline const std::filesystem::path& root() {
    struct Root {
        std::filesystem::path path;
        pid_t owner = ::getpid();
        Root() : path(std::filesystem::temp_directory_path() / ("iblbake_tests_" + std::to_string(::getpid()))) {
            std::filesystem::remove_all(path);
            std::filesystem::create_directories(path);
        }
        ~Root() {
            std::error_code ec;  // only the process that made it (not a fork) removes it
            if (::getpid() == owner) std::filesystem::remove_all(path, ec);
        }
    };
    static const Root root;
    return root.path;
}

// An empty folder `name` in this process's folder.
inline std::filesystem::path dir(const std::string& name) {
    const std::filesystem::path p = root() / name;
    std::filesystem::remove_all(p);
    std::filesystem::create_directories(p);
    return p;
}

}  // namespace iblbake::scratch
