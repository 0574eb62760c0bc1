// Shared by the robustness and regression tests: run a call and classify what it did, or run it
// in a child process, so that a crash fails one test only (CTest times out a hang).
#pragma once

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>
#include <typeinfo>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave::testing {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// What a call did: returned, threw tesswave::Error, or threw anything else (always a bug).
struct Outcome {
    enum Kind { returned, error, other } kind = returned;
    std::string what;
};

template <class F>
Outcome outcome_of(F&& f) {
    try {
        f();
        return {};
    } catch (const Error& e) {
        return {Outcome::error, e.what()};
    } catch (const std::exception& e) {
        return {Outcome::other, str(typeid(e).name(), ": ", e.what())};
    } catch (...) {
        return {Outcome::other, "an exception not derived from std::exception"};
    }
}

// Runs `body` in a child process (a gtest death test), so that a crash, a stack overflow or a
// sanitizer abort fails this test alone rather than the whole binary. The child exits with 0 when
// `body` returns or throws tesswave::Error; `body` may exit otherwise itself to report a wrong
// result. No clock here: a hang is caught by CTest's per-test timeout (tests/CMakeLists.txt).
template <class F>
void expect_error_or_return_in_child(F body) {
    // Other tests in this binary start library thread pools (OpenCV, OpenImageIO); a plain fork
    // of a threaded process can deadlock, so the child re-executes the binary instead.
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    EXPECT_EXIT(
        {
            try {
                body();
            } catch (const Error&) {
            }
            std::_Exit(0);
        },
        ::testing::ExitedWithCode(0), "");
}

// In a test's child process: the address space may grow by `extra` bytes only (an allocation
// past it throws std::bad_alloc). Not under AddressSanitizer, whose shadow memory it would refuse.
inline void cap_address_space(size_t extra) {
    size_t pages = 0;
    std::ifstream("/proc/self/statm") >> pages;
    const rlim_t cap = pages * static_cast<size_t>(sysconf(_SC_PAGESIZE)) + extra;
    const rlimit limit{cap, cap};
    setrlimit(RLIMIT_AS, &limit);
}

}  // namespace tesswave::testing
