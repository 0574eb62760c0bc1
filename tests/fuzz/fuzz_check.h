// Shared by the fuzz targets: a failed check aborts (so libFuzzer records a crash), and every
// tesswave::Error must carry a one-line, non-empty message.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string_view>

#include "core/math/error.h"

namespace tesswave::fuzz {

[[noreturn]] inline void fail(const char* target, const char* what) {
    std::fprintf(stderr, "%s: %s\n", target, what);
    std::abort();
}

inline void check_message(const char* target, const Error& e) {
    const std::string_view message = e.what();
    if (message.empty() || message.find('\n') != std::string_view::npos) {
        fail(target, "an error message is not one line");
    }
}

}  // namespace tesswave::fuzz
