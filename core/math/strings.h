// String building for messages (GCC 12 has no <format>): str("face ", f, ": not convex").
#pragma once

#include <sstream>
#include <string>
#include <string_view>

namespace tesswave {

template <class... Args>
std::string str(const Args&... args) {
    std::ostringstream out;
    out.precision(10);
    (out << ... << args);
    return out.str();
}

// Text files saved by some editors start with a UTF-8 byte-order mark; parsers skip it.
inline std::string_view without_bom(std::string_view text) {
    return text.substr(0, 3) == "\xEF\xBB\xBF" ? text.substr(3) : text;
}

}  // namespace tesswave
