// A private temporary folder for a test, unique to the process and the call (mkdtemp), removed
// with everything in it when it goes out of scope; parallel test runs never share one.
#pragma once

#include <stdlib.h>

#include <filesystem>
#include <string>
#include <system_error>

#include "core/math/error.h"

namespace tesswave::testing {

struct TempDir {
    std::filesystem::path path;

    explicit TempDir(const std::string& stem) {
        std::string pattern =
            (std::filesystem::temp_directory_path() / ("tesswave_" + stem + "_XXXXXX")).string();
        if (::mkdtemp(pattern.data()) == nullptr) throw Error("cannot make " + pattern);
        path = pattern;
    }
    ~TempDir() {
        std::error_code ignored;
        std::filesystem::remove_all(path, ignored);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    std::string operator/(const std::string& name) const { return (path / name).string(); }
    bool empty() const { return std::filesystem::is_empty(path); }
};

}  // namespace tesswave::testing
