#include "core/io/file_io.h"

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

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

namespace {

struct Note {
    char* path;  // strdup'd
    bool folder;
};

// Never destroyed: a signal may come while static destructors run, and the notes must stay
// reachable (a destroyed vector would leave its strings behind).
std::vector<Note>& notes() {
    static auto* list = new std::vector<Note>;
    return *list;
}

// Runs `change` with SIGINT and SIGTERM blocked, so that the handler never sees a half-made note.
template <class F>
void with_signals_blocked(F&& change) {
    sigset_t block, old;
    sigemptyset(&block);
    sigaddset(&block, SIGINT);
    sigaddset(&block, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &block, &old);
    change();
    pthread_sigmask(SIG_SETMASK, &old, nullptr);
}

void note(const std::string& path, bool folder) {
    with_signals_blocked([&] {
        if (char* copy = ::strdup(path.c_str())) notes().push_back({copy, folder});
    });
}

}  // namespace

void keep_run_outputs() {
    with_signals_blocked([] {
        for (Note& n : notes()) std::free(n.path);
        notes().clear();
    });
}

void remove_run_outputs() noexcept {
    const std::vector<Note>& list = notes();
    for (size_t i = list.size(); i-- > 0;) {
        if (!list[i].folder) ::unlink(list[i].path);
    }
    for (size_t i = list.size(); i-- > 0;) {
        if (list[i].folder) ::rmdir(list[i].path);
    }
}

void create_folders(const std::string& dir) {
    namespace fs = std::filesystem;
    std::vector<fs::path> missing;
    std::error_code ec;
    for (fs::path p = fs::absolute(dir, ec); !p.empty() && !fs::exists(p, ec);
         p = p.parent_path()) {
        missing.push_back(p);
        if (p == p.parent_path()) break;
    }
    for (size_t i = missing.size(); i-- > 0;) {
        fs::create_directory(missing[i], ec);
        if (ec) throw Error(str(dir, ": cannot create folder (", ec.message(), ")"));
        note(missing[i].string(), true);
    }
}

std::string temporary_name(const std::string& path) {
    // Hidden, beside the target, and with its extension: image writers choose the format by it.
    const std::filesystem::path p(path);
    const std::string name =
        str(".", p.stem().string(), ".tmp-", ::getpid(), p.extension().string());
    const std::string temporary = (p.parent_path() / name).string();
    note(temporary, false);
    return temporary;
}

void commit_temporary(const std::string& temporary, const std::string& path) {
    if (std::rename(temporary.c_str(), path.c_str()) != 0) {
        const std::string why = std::strerror(errno);
        discard_temporary(temporary);
        throw Error(str(path, ": cannot write (", why, ")"));
    }
    note(path, false);
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

std::string lowercase_extension(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return e;
}

}  // namespace tesswave
