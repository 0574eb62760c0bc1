// tesswave compare-morph: the classic morph beside our schedules on the same points.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "cli.h"
#include "cmd_morph.h"
#include "core/eval/contact_sheet.h"
#include "core/eval/peer_morph.h"
#include "core/io/image_io.h"
#include "core/math/error.h"
#include "core/math/project.h"
#include "core/math/strings.h"
#include "morph/faces.h"
#include "morph/morph.h"
#include "morph/pair.h"

namespace fs = std::filesystem;

namespace tesswave::cli {
namespace {

// compare-morph: the middle frames of the classic morph and of our schedules on the same points,
// side by side with crops, and the measures of peer_morph.h.
void run_compare_morph(const MorphArgs& a) {
    const auto start = std::chrono::steady_clock::now();
    const std::string ext = fs::path(a.output).extension().string();
    if (ext != ".png" && ext != ".jpg" && ext != ".tif") {
        throw CLI::ValidationError("-o", str(a.output, ": the contact sheet is an image (.png)"));
    }
    check_output(a.output, a.overwrite, {a.a, a.b});
    const Image ia = read_input(a.a), ib = read_input(a.b);
    morph::check_sample_estimate(a.a, ia.width, ia.height, a.density, a.levels);
    // The landmark model loads while the faces are detected (after the images: an unreadable
    // image is reported at once, not after the model's half second).
    if (a.automatic) morph::prepare_faces();
    nlohmann::json report = {{"a", a.a}, {"b", a.b}, {"output", a.output}, {"at", a.at}};
    ProgressBar bar;
    const Progress progress = [&bar](double done, const char* stage) { bar.update(done, stage); };
    bar.update(0.0, "correspondences");
    const Points points = correspondences(a, ia, ib, report, progress_range(progress, 0, 0.2));
    const morph::PairMeshes pair = pair_meshes(a, points, ia, ib);
    morph::check_samples(a.a, pair.a, ia.width, ia.height,
                         {.levels = a.levels, .density = a.density});
    report["correspondences"] = points.c.a.size();
    report["mesh"] = pair.description;
    if (!pair.repair.empty()) warn("note: " + pair.repair);
    // Crops where faces show ghosts first: the eyes and the jaw line (iBUG layout, 68 points and
    // more), else the centre; boxes on the shape at t.
    std::vector<std::pair<std::string, std::array<int, 4>>> crops;
    const auto box = [&](int from, int to, double pad) {
        double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
        for (int k = from; k <= to; ++k) {
            const Vec2 pa = points.c.a[k], pb = points.c.b[k];
            const Vec2 p = (1 - a.at) * pa +
                           a.at * Vec2{pb.x * ia.width / ib.width, pb.y * ia.height / ib.height};
            x0 = std::min(x0, p.x), y0 = std::min(y0, p.y);
            x1 = std::max(x1, p.x), y1 = std::max(y1, p.y);
        }
        const double w = x1 - x0, h = y1 - y0, m = pad * std::max(w, h);
        return std::array<int, 4>{static_cast<int>(x0 - m), static_cast<int>(y0 - m),
                                  static_cast<int>(w + 2 * m), static_cast<int>(h + 2 * m)};
    };
    if (points.landmarks && points.c.a.size() >= 68) {
        crops.push_back({"eyes", box(36, 47, 0.15)});
        crops.push_back({"jaw", box(4, 12, 0.1)});
    } else {
        crops.push_back({"centre", {ia.width / 3, ia.height / 3, ia.width / 3, ia.height / 3}});
    }
    struct Method {
        std::string name;
        Image middle, wa, wb;
        MorphMeasures m = {};
        double seconds = 0;
    };
    std::vector<Method> methods;
    {
        const auto t0 = std::chrono::steady_clock::now();
        const ClassicMorph classic(ia, ib, pair.a, pair.b);
        methods.push_back({"classic",
                           classic.frame(a.at),
                           classic.warped(a.at, 0),
                           classic.warped(a.at, 1),
                           {},
                           0});
        methods.back().seconds = seconds_since(t0);
    }
    const morph::ScheduleKind kinds[] = {morph::ScheduleKind::linear, morph::ScheduleKind::sharp,
                                         morph::ScheduleKind::bands, morph::ScheduleKind::aware};
    const char* names[] = {"linear", "sharp", "bands", "aware (default)"};
    for (int k = 0; k < 4; ++k) {
        bar.update(0.2 + 0.7 * k / 4, names[k]);
        const auto t0 = std::chrono::steady_clock::now();
        morph::MorphOptions o{.levels = a.levels, .density = a.density};
        o.sampling = sampling_from_name(a.sampling);
        o.schedule.kind = kinds[k];
        const morph::Morph m(ia, ib, pair.a, pair.b, o);
        methods.push_back({names[k], m.frame(a.at), m.warped(a.at, 0), m.warped(a.at, 1), {}, 0});
        methods.back().seconds = seconds_since(t0);
    }
    bar.update(0.9, "measures");
    std::vector<Image> tiles;
    std::vector<std::string> captions;
    const double frame_scale = std::min(1.0, 520.0 / std::max(ia.width, ia.height));
    for (Method& m : methods) {
        m.m = measure_middle(m.middle, m.wa, m.wb);
        report["methods"][m.name] = {{"detail", m.m.detail},
                                     {"kept", m.m.kept},
                                     {"ghost", m.m.ghost},
                                     {"seconds", m.seconds}};
        tiles.push_back(crop_scaled(m.middle, 0, 0, ia.width, ia.height, frame_scale));
        char caption[160];
        std::snprintf(caption, sizeof caption, "%s: detail %.2f, kept %.2f, ghost %.2f",
                      m.name.c_str(), m.m.detail, m.m.kept, m.m.ghost);
        captions.push_back(caption);
    }
    for (const auto& [what, r] : crops) {
        for (const Method& m : methods) {
            const double scale = std::min(4.0, ia.width * frame_scale / std::max(1, r[2]));
            tiles.push_back(crop_scaled(m.middle, r[0], r[1], r[2], r[3], scale));
            captions.push_back(str(m.name, ", ", what));
        }
    }
    write_image(contact_sheet(tiles, captions, {.columns = static_cast<int>(methods.size())}),
                a.output);
    bar.clear();
    report["seconds"] = seconds_since(start);
    if (a.json) {
        std::printf("%s\n", report.dump(2).c_str());
        return;
    }
    std::printf("%s + %s at t = %g: %s\n%-16s %7s %7s %7s %8s\n", a.a.c_str(), a.b.c_str(), a.at,
                pair.description.c_str(), "method", "detail", "kept", "ghost", "seconds");
    for (const Method& m : methods) {
        std::printf("%-16s %7.3f %7.3f %7.3f %8.2f\n", m.name.c_str(), m.m.detail, m.m.kept,
                    m.m.ghost, m.seconds);
    }
    std::printf(
        "detail: the middle frame's detail energy over the endpoints'; kept: the same where "
        "the endpoints correspond; ghost: detail matching one endpoint only (a dissolve: "
        "1/2 where nothing corresponds). Sheet: %s\n",
        a.output.c_str());
}

}  // namespace

void add_compare_morph_command(CLI::App& app) {
    auto c = std::make_shared<MorphArgs>();
    c->at = 0.5;
    CLI::App* cmd = app.add_subcommand(
        "compare-morph",
        "The classic morph (triangle warps + dissolve) beside our schedules: middle frames, crops "
        "and detail/ghost measures");
    cmd->add_option("a", c->a, "First image")->required();
    cmd->add_option("b", c->b, "Second image")->required();
    cmd->add_option("-o,--output", c->output, "Contact sheet (.png)")->required();
    auto* points_a = cmd->add_option("--points-a", c->points_a, "Points on A: 'x y' lines or JSON");
    auto* points_b = cmd->add_option("--points-b", c->points_b, "The corresponding points on B");
    points_a->needs(points_b);
    points_b->needs(points_a);
    cmd->add_flag("--faces", c->faces, "Use face landmarks (dlib) or fail when a face is missing")
        ->excludes(points_a);
    cmd->add_option("--mesh", c->mesh, "As in morph: triangulation, grid[:CxR] or voronoi[:N]");
    cmd->add_option("--at", c->at, "The frame compared")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_option("--density", c->density, "Mesh samples per output pixel")
        ->capture_default_str()
        ->check(density_range());
    cmd->add_option("-J,--levels", c->levels, "Mesh level J (default from --density)")
        ->check(CLI::Range(1, 10));
    add_sampling_option(cmd, c->sampling);
    cmd->add_flag("-y,--overwrite", c->overwrite, "Overwrite the sheet");
    cmd->add_flag("--json", c->json, "Print a JSON report");
    cmd->callback([c] {
        c->automatic = c->faces || c->points_a.empty();
        run_compare_morph(*c);
    });
}

}  // namespace tesswave::cli
