#include "cli.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "core/io/image_io.h"
#include "core/io/mesh_io.h"
#include "core/math/error.h"
#include "core/math/strings.h"
#include "core/math/validate.h"

namespace tesswave::cli {

void check_output(const std::string& path, bool overwrite, const std::vector<std::string>& inputs) {
    namespace fs = std::filesystem;
    std::error_code ec;
    for (const auto& in : inputs) {
        if (in.empty() || !fs::exists(in, ec)) continue;
        if (fs::equivalent(in, path, ec)) throw Error(path + ": output would overwrite an input");
        // A folder output (PNG frames) replaces the whole folder: no input may live inside it.
        if (fs::is_directory(path, ec)) {
            const fs::path folder = fs::canonical(path, ec), file = fs::canonical(in, ec);
            const auto [end, _] =
                std::mismatch(folder.begin(), folder.end(), file.begin(), file.end());
            if (!folder.empty() && end == folder.end()) {
                throw Error(path + ": output folder holds the input " + in);
            }
        }
    }
    if (fs::exists(path, ec) && !overwrite) {
        throw Error(path + ": already exists (use -y to overwrite)");
    }
    const fs::path parent = fs::path(path).parent_path();
    if (!parent.empty() && !fs::is_directory(parent, ec)) {
        throw Error(path + ": folder " + parent.string() + " does not exist");
    }
}

void check_folder(const std::string& dir, bool overwrite) {
    namespace fs = std::filesystem;
    std::error_code ec;
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

void prepare_folder(const std::string& dir, bool overwrite) {
    namespace fs = std::filesystem;
    check_folder(dir, overwrite);
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw Error(str(dir, ": cannot create folder (", ec.message(), ")"));
}

ProgressBar::ProgressBar() : enabled_(::isatty(2) != 0) {}

ProgressBar::~ProgressBar() {
    if (enabled_ && last_ >= 0) std::fprintf(stderr, "\r%70s\r", "");
}

void ProgressBar::update(double fraction, const char* stage) {
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
        throw Error(
            str(option, ": expected ", form, " with two positive numbers, got \"", text, "\""));
    }
    return {a, b};
}

}  // namespace

std::pair<double, double> parse_size(const std::string& text, const std::string& option) {
    auto [w, h] = parse_pair(text, option, "WxH");
    if (w > 1e7 || h > 1e7) throw Error(str(option, ": ", text, " is larger than 1e7"));
    return {w, h};
}

std::pair<int, int> parse_cells(const std::string& text, const std::string& option) {
    auto [c, r] = parse_pair(text, option, "CxR");
    if (c != std::floor(c) || r != std::floor(r) || c > 1e5 || r > 1e5) {
        throw Error(str(option, ": expected whole numbers CxR up to 100000, got \"", text, "\""));
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

}  // namespace tesswave::cli
