// String building for messages (GCC 12 has no <format>): str("face ", f, ": not convex").
#pragma once

#include <sstream>
#include <string>

namespace tesswave {

template <class... Args>
std::string str(const Args&... args) {
    std::ostringstream out;
    out.precision(10);
    (out << ... << args);
    return out.str();
}

}  // namespace tesswave
