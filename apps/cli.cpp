#include "cli.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/io/mesh_io.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/strings.h"
#include "core/math/validate.h"
#include "core/math/voronoi.h"

namespace tesswave::cli {

namespace {

// An input inside the folder `dir` (through symlinks too): a folder output could replace it.
// With `walk`, also a file anywhere in the folder that is an input under another name (a hard
// link): the output would take that name from the user's file. Subfolders it may not read are
// skipped.
void refuse_inputs_inside(const std::string& dir, const std::vector<std::string>& inputs,
                          bool walk) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::path folder = fs::weakly_canonical(dir, ec);
    if (ec || folder.empty()) return;
    struct Linked {
        dev_t device;
        ino_t inode;
        const std::string* name;
    };
    std::vector<Linked> linked;  // regular-file inputs with more than one name
    for (const auto& in : inputs) {
        if (in.empty() || !fs::exists(in, ec)) continue;
        const fs::path file = fs::canonical(in, ec);
        if (ec) continue;
        // Where the file is, and, for an input named through a symlink, where the link is:
        // replacing either changes what the user named as an input.
        std::vector<fs::path> places = {file};
        fs::path given = fs::path(in).lexically_normal();
        if (!given.has_filename()) given = given.parent_path();  // "link/"
        if (fs::is_symlink(fs::symlink_status(given, ec))) {
            places.push_back(fs::weakly_canonical(fs::absolute(given, ec).parent_path(), ec) /
                             given.filename());
        }
        for (const fs::path& place : places) {
            const auto [end, _] =
                std::mismatch(folder.begin(), folder.end(), place.begin(), place.end());
            if (end == folder.end()) throw Error(dir + ": output folder holds the input " + in);
        }
        struct stat st {};
        if (::stat(file.c_str(), &st) == 0 && S_ISREG(st.st_mode) && st.st_nlink > 1) {
            linked.push_back({st.st_dev, st.st_ino, &in});
        }
    }
    if (!walk || linked.empty() || !fs::is_directory(folder, ec)) return;
    for (auto it = fs::recursive_directory_iterator(
             folder, fs::directory_options::skip_permission_denied, ec);
         !ec && it != fs::end(it); it.increment(ec)) {
        struct stat st {};
        if (::lstat(it->path().c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
        for (const Linked& l : linked) {
            if (st.st_dev == l.device && st.st_ino == l.inode) {
                const fs::path inside = it->path().lexically_relative(folder);
                throw Error(str(dir, ": output folder holds ", inside.string(),
                                ", a hard link to the input ", *l.name));
            }
        }
    }
}

}  // namespace

void check_output(const std::string& path, bool overwrite, const std::vector<std::string>& inputs) {
    namespace fs = std::filesystem;
    std::error_code ec;
    for (const auto& in : inputs) {
        if (in.empty() || !fs::exists(in, ec)) continue;
        if (fs::equivalent(in, path, ec)) throw Error(path + ": output would overwrite an input");
    }
    // A path with an extension names a file (the kind follows from it): a folder there would fail
    // only after the work.
    if (fs::is_directory(path, ec) && fs::path(path).has_extension()) {
        throw Error(path + ": is a folder, and the output is a file");
    }
    // A folder output (PNG frames) gets its frames replaced: no input may live inside it.
    if (fs::is_directory(path, ec)) refuse_inputs_inside(path, inputs, overwrite);
    if (fs::exists(path, ec) && !overwrite) {
        throw Error(path + ": already exists (use -y to overwrite)");
    }
    const fs::path parent = fs::path(path).parent_path();
    if (!parent.empty() && !fs::is_directory(parent, ec)) {
        throw Error(path + ": folder " + parent.string() + " does not exist");
    }
}

void check_folder(const std::string& dir, bool overwrite, const std::vector<std::string>& inputs) {
    namespace fs = std::filesystem;
    std::error_code ec;
    // Without -y a folder that is not empty is refused anyway: its files need no walk.
    refuse_inputs_inside(dir, inputs, overwrite);
    if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
        throw Error(dir + ": exists and is not a folder");
    }
    if (fs::exists(dir, ec) && !fs::is_empty(dir, ec) && !overwrite) {
        throw Error(dir + ": folder is not empty (use -y to overwrite its files)");
    }
    // Missing parents are created when writing (like mkdir -p); a parent that is a file fails.
    for (fs::path p = fs::absolute(dir, ec).parent_path(); !p.empty() && p != p.parent_path();
         p = p.parent_path()) {
        if (fs::exists(p, ec)) {
            if (!fs::is_directory(p, ec)) throw Error(dir + ": " + p.string() + " is not a folder");
            break;
        }
    }
}

void prepare_folder(const std::string& dir, bool overwrite,
                    const std::vector<std::string>& inputs) {
    check_folder(dir, overwrite, inputs);
    create_folders(dir);
}

Image read_input(const std::string& path, const ImageLimits& limits) {
    ImageNotes notes;
    Image image = read_image(path, limits, &notes);
    if (notes.non_finite > 0) {
        warn(str("warning: ", path, ": ", notes.non_finite,
                 " values are NaN or infinite; they are read as 0"));
    }
    if (!notes.decoder.empty()) {
        std::string why = notes.decoder;
        std::replace(why.begin(), why.end(), '\n', ' ');
        warn(str("warning: ", path, ": the image may be damaged (", why, ")"));
    }
    return image;
}

Verbosity& verbosity() {
    static Verbosity level = Verbosity::normal;
    return level;
}

void warn(const std::string& line) {
    if (verbosity() != Verbosity::quiet) std::fprintf(stderr, "%s\n", line.c_str());
}

ProgressBar::ProgressBar() : enabled_(verbosity() == Verbosity::normal && ::isatty(2) != 0) {}

ProgressBar::~ProgressBar() { clear(); }

void ProgressBar::clear() {
    if (enabled_ && last_ >= 0) std::fprintf(stderr, "\r%70s\r", "");
    last_ = -1;
}

void ProgressBar::update(double fraction, const char* stage) {
    if (verbosity() == Verbosity::verbose && stage_ != stage) {
        stage_ = stage;
        std::fprintf(stderr, "[%8.2f s] %3.0f%% %s\n", seconds_since(start_),
                     std::clamp(fraction, 0.0, 1.0) * 100, stage);
    }
    if (!enabled_) return;
    const int percent = static_cast<int>(std::lround(std::clamp(fraction, 0.0, 1.0) * 100));
    if (percent == last_) return;
    last_ = percent;
    const int filled = percent * 30 / 100;
    std::fprintf(stderr, "\r[%.*s%.*s] %3d%% %-30s", filled, "##############################",
                 30 - filled, "..............................", percent, stage);
    std::fflush(stderr);
}

namespace {

std::pair<double, double> parse_pair(const std::string& text, const std::string& option,
                                     const char* form) {
    std::string t = text;
    for (char& c : t) c = (c == 'x' || c == 'X' || c == ',') ? ' ' : c;
    std::istringstream in(t);
    double a, b;
    std::string rest;
    if (!(in >> a >> b) || (in >> rest) || !std::isfinite(a) || !std::isfinite(b) || a <= 0 ||
        b <= 0) {
        throw CLI::ValidationError(
            option, str("expected ", form, " with two positive numbers, got \"", text, "\""));
    }
    return {a, b};
}

}  // namespace

std::pair<double, double> parse_size(const std::string& text, const std::string& option) {
    auto [w, h] = parse_pair(text, option, "WxH");
    if (w > 1e7 || h > 1e7) throw CLI::ValidationError(option, str(text, " is larger than 1e7"));
    return {w, h};
}

std::pair<int, int> parse_cells(const std::string& text, const std::string& option) {
    auto [c, r] = parse_pair(text, option, "CxR");
    if (c != std::floor(c) || r != std::floor(r) || c > 1e5 || r > 1e5) {
        throw CLI::ValidationError(
            option, str("expected whole numbers CxR up to 100000, got \"", text, "\""));
    }
    return {static_cast<int>(c), static_cast<int>(r)};
}

Mesh read_mesh_for(const std::string& mesh_path, const std::string& image_path, const Image& image,
                   bool fit) {
    const double W = image.width, H = image.height;
    Mesh mesh = read_mesh(mesh_path);
    if (mesh.width != W || mesh.height != H) {
        if (!fit) {
            throw Error(str(mesh_path, ": mesh domain ", mesh.width, "x", mesh.height,
                            " does not match ", image_path, " (", image.width, "x", image.height,
                            "); use --fit-mesh to scale it"));
        }
        const double sx = W / mesh.width, sy = H / mesh.height;
        for (Vec2& p : mesh.vertices) {
            p = {p.x == mesh.width ? W : p.x * sx, p.y == mesh.height ? H : p.y * sy};
        }
        mesh.width = W;
        mesh.height = H;
    }
    require_valid(mesh, mesh_path);
    return mesh;
}

bool is_mesh_generator(const std::string& spec) {
    const std::string kind = spec.substr(0, spec.find(':'));
    return kind == "grid" || kind == "voronoi";
}

Mesh generated_mesh(const std::string& spec, double width, double height) {
    const size_t colon = spec.find(':');
    const std::string kind = spec.substr(0, colon);
    const std::string count = colon == std::string::npos ? "" : spec.substr(colon + 1);
    if (kind == "grid") {
        auto [c, r] = count.empty()
                          ? std::pair{std::max(1, static_cast<int>(std::lround(width / 24))),
                                      std::max(1, static_cast<int>(std::lround(height / 24)))}
                          : parse_cells(count, "--mesh grid");
        if (c > std::max(1.0, width) || r > std::max(1.0, height)) {
            throw CLI::ValidationError(
                "--mesh", str("grid:", c, "x", r, " has more cells than the ", width, "x", height,
                              " pixels of the domain"));
        }
        return grid_mesh(width, height, c, r);
    }
    if (kind == "voronoi") {
        int sites = std::max(4, static_cast<int>(width * height / 576));
        if (!count.empty()) {
            size_t used = 0;
            long long n = 0;
            try {
                n = std::stoll(count, &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used != count.size() || n < 1 || n > 1'000'000) {
                throw CLI::ValidationError(
                    "--mesh", str("voronoi:N needs N from 1 to 1000000, got \"", count, "\""));
            }
            sites = static_cast<int>(n);
            // Cells smaller than a pixel carry nothing and cost Voronoi and validation time
            // growing faster than the count (10^6 sites on 64x48 ran past a minute).
            const double cells = std::max(1.0, std::floor(width * height));
            if (sites > cells) {
                throw CLI::ValidationError(
                    "--mesh", str("voronoi:", sites, " has more cells than the ", cells,
                                  " pixels of the domain"));
            }
        }
        return voronoi_mesh(width, height, {.sites = sites, .seed = 1, .lloyd_iterations = 2});
    }
    throw CLI::ValidationError("--mesh", str("'", spec, "' is not grid[:CxR] or voronoi[:N]"));
}

Mesh mesh_for(const std::string& spec, const std::string& image_path, const Image& image,
              bool fit) {
    if (is_mesh_generator(spec)) return generated_mesh(spec, image.width, image.height);
    return read_mesh_for(spec, image_path, image, fit);
}

const char* transform_name(TwiTransform t) {
    return t == TwiTransform::mesh ? "mesh" : t == TwiTransform::grid53 ? "grid 5/3" : "grid 9/7";
}

CLI::Validator positive(const std::string& what) {
    return CLI::Validator(
        [what](std::string& text) {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (text.empty() || *end != '\0' || !(v > 0) || !std::isfinite(v)) {
                return str("must be ", what, " above 0, not '", text, "'");
            }
            return std::string();
        },
        "POSITIVE");
}

CLI::Validator output_extension(std::vector<std::string> extensions, const std::string& job,
                                const std::string& kinds) {
    return CLI::Validator(
        [extensions = std::move(extensions), job, kinds](std::string& path) {
            const std::string ext = lowercase_extension(path);
            for (const std::string& e : extensions) {
                if (ext == e) return std::string();
            }
            return str(path, ": ", job, " writes ", kinds);
        },
        "");
}

CLI::Validator image_output() {
    return CLI::Validator(
        [](std::string& path) {
            if (image_writable(path)) return std::string();
            return str(path,
                       ": not an image file name that can be written (.png, .tif, .jpg, "
                       ".exr, ...)");
        },
        "");
}

void refuse_unused(const CLI::App& cmd, std::initializer_list<const char*> options, bool applies,
                   const std::string& when) {
    if (applies) return;
    for (const char* option : options) {
        if (cmd.count(option) > 0) throw CLI::ValidationError(option, "applies to " + when);
    }
}

bool is_h264_output(const std::string& path) {
    const std::string ext = lowercase_extension(path);
    return ext == ".mp4" || ext == ".mov";
}

}  // namespace tesswave::cli
