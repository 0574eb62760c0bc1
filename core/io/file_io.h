// Whole-file reads with a size limit, and atomic writes (temporary name, then rename), so a
// failed command never leaves a partial output and never touches its inputs.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace tesswave {

// Throws Error("<path>: ...") when the file cannot be read or is larger than max_bytes.
// A path's extension in lower case, with its dot ("" for none): what the kind of a file follows.
std::string lowercase_extension(const std::string& path);

std::string read_file(const std::string& path, int64_t max_bytes = int64_t{1} << 30);

// Writes to a temporary name beside path (".<stem>.tmp-<pid><ext>") and renames it over path;
// removes the temporary on failure.
void write_file_atomic(const std::string& path, std::string_view bytes);

// A temporary name beside `path` for writers that produce the file themselves (image writers);
// commit_temporary renames it into place, discard_temporary removes it.
std::string temporary_name(const std::string& path);
void commit_temporary(const std::string& temporary, const std::string& path);
void discard_temporary(const std::string& temporary) noexcept;

// Creates `dir` and any missing parents, noting each folder it creates (below).
void create_folders(const std::string& dir);

// What an interrupted run leaves behind. Every temporary name handed out, every file committed
// and every folder created since the last keep_run_outputs() is noted, so that a signal handler
// can remove them with remove_run_outputs(): files first, then the folders, newest first (a
// folder that still holds other files stays). remove_run_outputs is async-signal-safe (unlink
// and rmdir only); the notes are changed with SIGINT and SIGTERM blocked.
void keep_run_outputs();
void remove_run_outputs() noexcept;

}  // namespace tesswave
