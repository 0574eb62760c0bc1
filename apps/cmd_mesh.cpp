// tesswave mesh grid|voronoi|triangulate|validate|info|draw
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "core/eval/mesh_draw.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/io/mesh_io.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/hierarchy.h"
#include "core/math/strings.h"
#include "core/math/triangulate.h"
#include "core/math/validate.h"
#include "core/math/voronoi.h"

namespace tesswave::cli {
namespace {

// Domain of a generated mesh: --size WxH, or the pixel size of --like IMG.
struct DomainArgs {
    std::string size = "1024x768";
    std::string like;
    std::pair<double, double> resolve() const {
        if (!like.empty()) {
            const Image image = read_input(like);
            return {image.width, image.height};
        }
        return parse_size(size, "--size");
    }
};

struct OutputArgs {
    std::string path;
    bool overwrite = false;
};

void add_domain(CLI::App* cmd, DomainArgs& d) {
    cmd->add_option("--size", d.size, "Domain WxH in pixels")->capture_default_str();
    cmd->add_option("--like", d.like, "Take the domain size from this image");
}

bool is_svg(const std::string& path) { return lowercase_extension(path) == ".svg"; }

void add_output(CLI::App* cmd, OutputArgs& o, const std::string& what, const CLI::Validator& kind) {
    cmd->add_option("-o,--output", o.path, what)->required()->check(kind);
    cmd->add_flag("-y,--overwrite", o.overwrite, "Overwrite existing outputs");
}

void finish_generated(const Mesh& mesh, const OutputArgs& out, const std::string& what) {
    require_valid(mesh, what);
    write_mesh(mesh, out.path);
    std::printf("%s: %d vertices, %d faces -> %s\n", what.c_str(), mesh.num_vertices(),
                mesh.num_faces(), out.path.c_str());
}

void add_grid(CLI::App& mesh_cmd) {
    struct Args {
        std::string cells;
        DomainArgs domain;
        OutputArgs out;
    };
    auto args = std::make_shared<Args>();
    auto* cmd = mesh_cmd.add_subcommand("grid", "Regular grid of CxR rectangular cells");
    cmd->add_option("--cells", args->cells, "Cells as CxR, e.g. 8x6")->required();
    add_domain(cmd, args->domain);
    add_output(cmd, args->out, "Mesh file to write (.json)",
               output_extension({".json"}, str("mesh ", cmd->get_name()), "a mesh file (.json)"));
    cmd->callback([args] {
        check_output(args->out.path, args->out.overwrite, {args->domain.like});
        auto [w, h] = args->domain.resolve();
        auto [c, r] = parse_cells(args->cells, "--cells");
        // As --mesh grid:CxR: no cell smaller than a pixel (they carry nothing and cost time and
        // memory growing with the count: 3000x3000 on 1024x768 ran past a minute at 1.7 GB).
        if (c > std::max(1.0, w) || r > std::max(1.0, h)) {
            throw CLI::ValidationError("--cells", str(c, "x", r, " cells is more than the ", w, "x",
                                                      h, " pixels of the domain"));
        }
        finish_generated(grid_mesh(w, h, c, r), args->out, "grid");
    });
}

void add_voronoi(CLI::App& mesh_cmd) {
    struct Args {
        int sites = 64;
        int64_t seed = 1;
        int lloyd = 0;
        DomainArgs domain;
        OutputArgs out;
    };
    auto args = std::make_shared<Args>();
    auto* cmd = mesh_cmd.add_subcommand("voronoi", "Voronoi cells of N random sites");
    cmd->add_option("-n,--sites", args->sites, "Number of sites (cells)")
        ->capture_default_str()
        ->check(CLI::Range(1, 1'000'000));
    cmd->add_option("--seed", args->seed, "Random seed (0 or more)")
        ->capture_default_str()
        ->check(CLI::Validator(
            [](const std::string& v) {
                return v.starts_with('-') ? std::string("must be 0 or more") : std::string();
            },
            "SEED"));
    cmd->add_option("--lloyd", args->lloyd, "Lloyd relaxation iterations")
        ->capture_default_str()
        ->check(CLI::Range(0, 1000));
    add_domain(cmd, args->domain);
    add_output(cmd, args->out, "Mesh file to write (.json)",
               output_extension({".json"}, str("mesh ", cmd->get_name()), "a mesh file (.json)"));
    cmd->callback([args] {
        check_output(args->out.path, args->out.overwrite, {args->domain.like});
        auto [w, h] = args->domain.resolve();
        // As --mesh voronoi:N: no more cells than pixels.
        if (args->sites > std::max(1.0, std::floor(w * h))) {
            throw CLI::ValidationError("--sites", str(args->sites, " cells is more than the ", w,
                                                      "x", h, " pixels of the domain"));
        }
        const Mesh mesh = voronoi_mesh(w, h,
                                       {.sites = args->sites,
                                        .seed = static_cast<uint64_t>(args->seed),
                                        .lloyd_iterations = args->lloyd});
        finish_generated(mesh, args->out, "voronoi");
    });
}

void add_triangulate(CLI::App& mesh_cmd) {
    struct Args {
        std::string points;
        int border = 0;
        DomainArgs domain;
        OutputArgs out;
    };
    auto args = std::make_shared<Args>();
    auto* cmd = mesh_cmd.add_subcommand(
        "triangulate", "Delaunay triangulation of given points plus the domain corners");
    cmd->add_option("points", args->points, "Point list (\"x y\" per line, or JSON [[x,y],...])")
        ->required();
    // Up to 1000 a side: points on the border alone make every insertion's cavity span the domain
    // (the triangles are slivers), so the work grows with their square (1000: 0.5 s, 20000: 8 s
    // and 1.5 GB).
    cmd->add_option("--border-points", args->border, "Extra evenly spaced points on each side")
        ->capture_default_str()
        ->check(CLI::Range(0, 1000));
    add_domain(cmd, args->domain);
    add_output(cmd, args->out, "Mesh file to write (.json)",
               output_extension({".json"}, str("mesh ", cmd->get_name()), "a mesh file (.json)"));
    cmd->callback([args] {
        check_output(args->out.path, args->out.overwrite, {args->points, args->domain.like});
        auto [w, h] = args->domain.resolve();
        const auto points = read_points(args->points);
        if (points.empty()) throw Error(str(args->points, ": no points"));
        Mesh mesh;
        try {
            mesh = triangulate_points(w, h, points, {.border_points_per_side = args->border});
        } catch (const Error& e) {
            throw Error(args->points + ": " + e.what());
        }
        finish_generated(mesh, args->out, "triangulation");
    });
}

void add_validate(CLI::App& mesh_cmd) {
    struct Args {
        std::string path;
        bool json = false;
    };
    auto args = std::make_shared<Args>();
    auto* cmd = mesh_cmd.add_subcommand("validate", "Check a mesh against every rule");
    cmd->add_option("mesh", args->path, "Mesh file (.json)")->required();
    cmd->add_flag("--json", args->json, "Print the result as JSON");
    cmd->callback([args] {
        const Mesh mesh = read_mesh(args->path);
        const ValidationReport report = validate(mesh);
        if (args->json) {
            nlohmann::json j = {{"file", args->path},
                                {"valid", report.ok()},
                                {"problems", report.problems},
                                {"stopped", report.stopped},
                                {"vertices", mesh.num_vertices()},
                                {"faces", mesh.num_faces()},
                                {"features", mesh.features.size()}};
            std::printf("%s\n", j.dump(2).c_str());
        } else if (report.ok()) {
            std::printf("%s: valid (%d vertices, %d faces, %zu feature edges)\n",
                        args->path.c_str(), mesh.num_vertices(), mesh.num_faces(),
                        mesh.features.size());
        }
        if (!report.ok()) {
            if (!args->json) {
                // The first three problems of each kind (the message with its numbers left
                // out), then how many more of that kind there are.
                std::vector<std::pair<std::string, int>> kinds;
                const auto kind_of = [](const std::string& p) {
                    std::string k;
                    for (char c : p) {
                        const bool digit = c >= '0' && c <= '9';
                        if (!digit || k.empty() || k.back() != '#') k += digit ? '#' : c;
                    }
                    return k;
                };
                for (const auto& p : report.problems) {
                    const std::string k = kind_of(p);
                    auto it = std::find_if(kinds.begin(), kinds.end(),
                                           [&](const auto& e) { return e.first == k; });
                    if (it == kinds.end()) it = kinds.insert(kinds.end(), {k, 0});
                    if (++it->second <= 3) {
                        std::fprintf(stderr, "tesswave: %s: %s\n", args->path.c_str(), p.c_str());
                    }
                }
                for (const auto& [k, count] : kinds) {
                    if (count > 3) {
                        std::fprintf(stderr, "tesswave: %s: %d more like \"%s\"\n",
                                     args->path.c_str(), count - 3, k.c_str());
                    }
                }
                std::fprintf(stderr, "tesswave: %s: %zu problem%s%s\n", args->path.c_str(),
                             report.problems.size(), report.problems.size() == 1 ? "" : "s",
                             report.stopped
                                 ? " shown; there are more (the checks stopped at the next)"
                                 : " in all");
            }
            throw CLI::RuntimeError(1);
        }
    });
}

void add_info(CLI::App& mesh_cmd) {
    struct Args {
        std::string path;
        int levels = 7;
        bool json = false;
    };
    auto args = std::make_shared<Args>();
    auto* cmd = mesh_cmd.add_subcommand("info", "Counts of T_0..T_J of a mesh");
    cmd->add_option("mesh", args->path, "Mesh file (.json)")->required();
    cmd->add_option("-J,--levels", args->levels, "Finest level J")
        ->capture_default_str()
        ->check(CLI::Range(0, 30));
    cmd->add_flag("--json", args->json, "Print {\"levels\":[...]} as JSON");
    cmd->callback([args] {
        const Mesh mesh = read_mesh(args->path);
        require_valid(mesh, args->path);
        const auto counts = level_counts(mesh, args->levels);
        if (args->json) {
            nlohmann::json levels = nlohmann::json::array();
            for (const auto& c : counts) {
                levels.push_back({{"level", c.level},
                                  {"vertices", c.vertices},
                                  {"edges", c.edges},
                                  {"faces", c.faces},
                                  {"boundary_edges", c.boundary_edges}});
            }
            std::printf("%s\n", nlohmann::json{{"levels", levels}}.dump().c_str());
            return;
        }
        const int64_t samples = sample_count(mesh, args->levels);
        std::printf("%s: domain %g x %g, %zu feature edges\n", args->path.c_str(), mesh.width,
                    mesh.height, mesh.features.size());
        std::printf("%6s %14s %14s %14s %15s %13s\n", "level", "vertices", "edges", "faces",
                    "boundary edges", "per pixel");
        for (const auto& c : counts) {
            std::printf("%6d %14lld %14lld %14lld %15lld %13.3f\n", c.level,
                        static_cast<long long>(c.vertices), static_cast<long long>(c.edges),
                        static_cast<long long>(c.faces), static_cast<long long>(c.boundary_edges),
                        static_cast<double>(c.vertices) / (mesh.width * mesh.height));
        }
        std::printf(
            "samples at level %d (feature sides counted twice): %lld, hierarchy ~%lld MiB\n",
            args->levels, static_cast<long long>(samples),
            static_cast<long long>(hierarchy_bytes(samples) >> 20));
    });
}

void add_draw(CLI::App& mesh_cmd) {
    struct Args {
        std::string path, image;
        DrawOptions draw;
        OutputArgs out;
    };
    auto args = std::make_shared<Args>();
    auto* cmd = mesh_cmd.add_subcommand(
        "draw", "Picture of T0 (bold) and its refinement levels (thin), PNG or SVG");
    cmd->add_option("mesh", args->path, "Mesh file (.json)")->required();
    cmd->add_option("-J,--levels", args->draw.levels, "Refinement levels to draw")
        ->capture_default_str()
        ->check(CLI::Range(0, 8));
    cmd->add_option("--image", args->image, "Draw over this image");
    cmd->add_option("--scale", args->draw.scale,
                    "Output pixels per domain unit (default: the image's, else ~1024 px wide)")
        ->check(CLI::Range(0.001, 64.0));
    cmd->add_option("--line-width", args->draw.line_width, "Width of the thin lines in pixels")
        ->capture_default_str()
        ->check(CLI::Range(0.5, 20.0));
    add_output(cmd, args->out, "Picture to write (.png, .jpg, .tif, ... or .svg)",
               CLI::Validator(
                   [](std::string& path) {
                       if (is_svg(path)) return std::string();
                       std::string image = path;
                       return image_output()(image);
                   },
                   ""));
    cmd->callback([args] {
        check_output(args->out.path, args->out.overwrite, {args->path, args->image});
        const Mesh mesh = read_mesh(args->path);
        require_valid(mesh, args->path);
        // The drawing's errors (a level too fine for the picture) name the mesh file.
        const auto drawn = [&](const auto& draw) {
            try {
                return draw();
            } catch (const Error& e) {
                throw Error(str(args->path, ": ", e.what()));
            }
        };
        const bool svg = is_svg(args->out.path);
        // One SVG element an edge: an SVG past 10 MB is said to be one, with what makes it (a
        // 4-face mesh at -J 8 wrote 38 MB without a word; a level too fine for the picture is
        // refused by the drawing itself).
        const auto warn_svg_size = [&](size_t bytes) {
            if (bytes <= 10'000'000) return;
            warn(str("warning: ", args->out.path, ": T0 and ", args->draw.levels,
                     " refinement levels make an SVG of ", bytes / 1'000'000,
                     " MB (fewer --levels, or a PNG, is lighter)"));
        };
        if (svg) {
            std::string href;
            if (!args->image.empty()) {
                read_input(args->image);  // fail now, not in the viewer
                const auto dir = std::filesystem::absolute(args->out.path).parent_path();
                href =
                    std::filesystem::relative(std::filesystem::absolute(args->image), dir).string();
            }
            const std::string picture =
                drawn([&] { return draw_mesh_svg(mesh, args->draw, href); });
            warn_svg_size(picture.size());
            write_file_atomic(args->out.path, picture);
        } else {
            std::unique_ptr<Image> background;
            if (!args->image.empty()) {
                background = std::make_unique<Image>(read_input(args->image));
                if (args->draw.scale == 0) args->draw.scale = background->width / mesh.width;
            }
            write_image(drawn([&] { return draw_mesh(mesh, args->draw, background.get()); }),
                        args->out.path);
        }
        std::printf("%s: T0 and %d refinement levels -> %s\n", args->path.c_str(),
                    args->draw.levels, args->out.path.c_str());
    });
}

}  // namespace

void add_mesh_commands(CLI::App& app) {
    auto* mesh = app.add_subcommand("mesh", "Make, check, inspect and draw tessellations");
    mesh->require_subcommand(1);
    add_grid(*mesh);
    add_voronoi(*mesh);
    add_triangulate(*mesh);
    add_validate(*mesh);
    add_info(*mesh);
    add_draw(*mesh);
}

}  // namespace tesswave::cli
