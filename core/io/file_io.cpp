#include "core/io/file_io.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {

std::string read_file(const std::string& path, int64_t max_bytes) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) throw Error(path + ": is a directory, not a file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error(str(path, ": cannot open (", std::strerror(errno), ")"));
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    if (size < 0) throw Error(path + ": cannot determine the file size");
    if (size > max_bytes) {
        throw Error(str(path, ": ", size, " bytes is larger than the limit of ", max_bytes));
    }
    std::string bytes(static_cast<size_t>(size), '\0');
    in.seekg(0);
    in.read(bytes.data(), size);
    if (!in) throw Error(path + ": read error");
    return bytes;
}

std::string temporary_name(const std::string& path) {
    // Hidden, beside the target, and with its extension: image writers choose the format by it.
    const std::filesystem::path p(path);
    const std::string name =
        str(".", p.stem().string(), ".tmp-", ::getpid(), p.extension().string());
    return (p.parent_path() / name).string();
}

void commit_temporary(const std::string& temporary, const std::string& path) {
    if (std::rename(temporary.c_str(), path.c_str()) != 0) {
        const std::string why = std::strerror(errno);
        discard_temporary(temporary);
        throw Error(str(path, ": cannot write (", why, ")"));
    }
}

void discard_temporary(const std::string& temporary) noexcept { std::remove(temporary.c_str()); }

void write_file_atomic(const std::string& path, std::string_view bytes) {
    const std::string tmp = temporary_name(path);
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        if (!out) throw Error(str(path, ": cannot write (", std::strerror(errno), ")"));
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        out.flush();
        if (!out) {
            discard_temporary(tmp);
            throw Error(path + ": write error");
        }
    }
    commit_temporary(tmp, path);
}

}  // namespace tesswave
