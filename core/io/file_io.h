// Whole-file reads with a size limit, and atomic writes (temporary name, then rename), so a
// failed command never leaves a partial output and never touches its inputs.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace tesswave {

// Throws Error("<path>: ...") when the file cannot be read or is larger than max_bytes.
std::string read_file(const std::string& path, int64_t max_bytes = int64_t{1} << 30);

// Writes to a temporary name beside path (".<stem>.tmp-<pid><ext>") and renames it over path;
// removes the temporary on failure.
void write_file_atomic(const std::string& path, std::string_view bytes);

// A temporary name beside `path` for writers that produce the file themselves (image writers);
// commit_temporary renames it into place, discard_temporary removes it.
std::string temporary_name(const std::string& path);
void commit_temporary(const std::string& temporary, const std::string& path);
void discard_temporary(const std::string& temporary) noexcept;

}  // namespace tesswave
