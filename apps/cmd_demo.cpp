// tesswave demo: generates the built-in samples and runs every job that exists on them.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>

#include "cli.h"
#include "core/codec/still_codec.h"
#include "core/eval/contact_sheet.h"
#include "core/eval/mesh_draw.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/io/mesh_io.h"
#include "core/io/video_io.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/hierarchy.h"
#include "core/math/lifting.h"
#include "core/math/metrics.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"
#include "core/math/triangulate.h"
#include "core/math/validate.h"
#include "core/math/voronoi.h"
#include "morph/inbetween.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"
#include "samples/sample_pair.h"

namespace tesswave::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Demo {
    fs::path dir;
    std::vector<std::string> written;
    std::string out(const std::string& name) {
        written.push_back((dir / name).string());
        return (dir / name).string();
    }
};

// Transform facts on the paper's setup: T0 of 20 vertices and 14 faces refined to level 7.
nlohmann::json transform_report(const Mesh& mesh, const Image& image) {
    auto t = Clock::now();
    const Hierarchy h = build_hierarchy(mesh, {.levels = 7});
    const double build_s = seconds_since(t);
    const auto p = refine_positions(h, mesh.vertices, 7);
    auto planes = sample_bilinear(image, p);
    const auto original = planes;
    std::vector<std::span<float>> spans(planes.begin(), planes.end());
    t = Clock::now();
    forward_transform(h, spans);
    const double forward_s = seconds_since(t);
    const int32_t n0 = h.num_samples(0);
    size_t small = 0, details = 0;
    for (const auto& plane : planes) {
        for (size_t i = n0; i < plane.size(); ++i) small += std::abs(plane[i]) < 0.5f / 255;
        details += plane.size() - n0;
    }
    t = Clock::now();
    inverse_transform(h, spans);
    const double inverse_s = seconds_since(t);
    double max_error = 0;
    for (size_t c = 0; c < planes.size(); ++c) {
        for (size_t i = 0; i < planes[c].size(); ++i) {
            max_error = std::max(max_error, std::abs(double{planes[c][i]} - original[c][i]));
        }
    }
    // Integer lifting on the 8-bit values: must come back bit-exact.
    std::vector<int32_t> ints(p.size());
    for (size_t i = 0; i < p.size(); ++i) ints[i] = std::lround(original[0][i] * 255);
    const auto ints0 = ints;
    std::span<int32_t> ispan[] = {ints};
    forward_transform_int(h, ispan);
    inverse_transform_int(h, ispan);
    // Linear precision: a ramp has no detail at all.
    std::vector<double> ramp(p.size());
    for (size_t i = 0; i < p.size(); ++i) ramp[i] = 0.2 + 0.003 * p[i].x - 0.001 * p[i].y;
    std::span<double> rspan[] = {ramp};
    forward_transform(h, rspan);
    double max_ramp_detail = 0;
    for (size_t i = n0; i < ramp.size(); ++i) {
        max_ramp_detail = std::max(max_ramp_detail, std::abs(ramp[i]));
    }
    return {
        {"levels", 7},
        {"samples", h.num_samples(7)},
        {"samples_per_pixel", static_cast<double>(h.num_samples(7)) / (image.width * image.height)},
        {"build_seconds", build_s},
        {"forward_seconds", forward_s},
        {"inverse_seconds", inverse_s},
        {"details_below_half_a_grey_level", static_cast<double>(small) / details},
        {"float_round_trip_max_error", max_error},
        {"integer_round_trip_exact", ints == ints0},
        {"ramp_max_detail", max_ramp_detail}};
}

// The still codec on the sample scene: four transforms at 0.5 bpp, progressive decoding of the
// mesh file's prefixes, and lossless coding checked bit for bit.
void codec_demo(const Image& scene, Demo& demo) {
    std::printf("\nstill codec (.twi) on scene.png at 0.5 bpp, then lossless:\n");
    const int64_t budget = static_cast<int64_t>(0.5 * scene.width * scene.height / 8);
    const std::pair<const char*, StillOptions> methods[] = {
        {"mesh", {.max_bytes = budget}},
        {"mesh_aligned", {.max_bytes = budget, .aligned = true}},
        {"grid53", {.transform = TwiTransform::grid53, .max_bytes = budget}},
        {"grid97", {.transform = TwiTransform::grid97, .max_bytes = budget}}};
    std::vector<uint8_t> mesh_file;
    for (const auto& [name, options] : methods) {
        const StillResult r = compress_image(scene, options);
        const std::string path = demo.out(str("codec_", name, ".twi"));
        write_file_atomic(path, {reinterpret_cast<const char*>(r.file.data()), r.file.size()});
        std::printf("  %-13s %6zu bytes  PSNR %6.2f dB\n", name, r.file.size(), r.psnr);
        if (mesh_file.empty()) mesh_file = r.file;
    }
    std::vector<Image> tiles;
    std::vector<std::string> captions;
    for (double fraction : {0.125, 0.25, 0.5, 1.0}) {
        const size_t n = static_cast<size_t>(fraction * mesh_file.size());
        tiles.push_back(decompress_image(mesh_file, "mesh file", {.max_bytes = n}));
        captions.push_back(
            str(n, " bytes, ", std::lround(psnr(scene, tiles.back()).all * 10) / 10.0, " dB"));
    }
    write_image(contact_sheet(tiles, captions, {.columns = 4}), demo.out("codec_progressive.png"));
    for (const auto& [name, options] :
         {std::pair{"grid53", StillOptions{.transform = TwiTransform::grid53, .lossless = true}},
          std::pair{"mesh_aligned", StillOptions{.lossless = true, .aligned = true}}}) {
        const StillResult r = compress_image(scene, options);
        const Image back = decompress_image(r.file, name);
        const bool exact = psnr(scene, back).mse_all == 0;
        std::printf("  lossless %-13s %6zu bytes  %.3f bpp  %s\n", name, r.file.size(),
                    r.file.size() * 8.0 / (scene.width * scene.height),
                    exact ? "bit-exact" : "NOT EXACT");
        if (!exact) throw Error(str("lossless ", name, " did not round-trip"));
    }
}

// The morph of the sample pair with a known deformation: points given and found automatically,
// a GIF and an MP4, and the middle frame against the true in-between.
void morph_demo(Demo& demo) {
    std::printf("\nmorph of the sample pair (known smooth deformation, 256x192):\n");
    const samples::SamplePair p = samples::deformed_pair(256, 192, 60);
    write_image(p.a, demo.out("morph_a.png"));
    write_image(p.b, demo.out("morph_b.png"));
    const Image truth = samples::moved(p.a, p.deformation, 0.5);
    const morph::PairMeshes pairs[] = {
        morph::triangulated_pair({p.points_a, p.points_b}, 256, 192, 256, 192),
        morph::automatic_pair(p.a, p.b, 16)};
    const char* names[] = {"60 given points, triangulated",
                           "automatic (flow + features), fitted grid"};
    for (int k = 0; k < 2; ++k) {
        double sq = 0;
        for (size_t i = 0; i < pairs[k].a.vertices.size(); ++i) {
            const Vec2 e = pairs[k].b.vertices[i] - p.deformation.at(pairs[k].a.vertices[i], 1.0);
            sq += dot(e, e);
        }
        const morph::Morph m(p.a, p.b, pairs[k].a, pairs[k].b, {});
        std::printf("  %-42s mesh error %.3f px RMS, middle frame %.2f dB against the truth\n",
                    names[k], std::sqrt(sq / pairs[k].a.vertices.size()),
                    psnr(truth, m.frame(0.5)).all);
        if (k == 1) {
            std::vector<Image> frames;
            VideoWriter video(demo.out("morph.mp4"), 256, 192, {.fps = 25});
            for (int f = 0; f < 25; ++f) {
                frames.push_back(m.frame(f / 24.0));
                video.write(frames.back());
            }
            video.finish();
            write_gif(frames, demo.out("morph.gif"), 25);
        }
    }
}

void run_demo(const fs::path& dir, bool overwrite) {
    prepare_folder(dir.string(), overwrite);
    Demo demo{dir, {}};
    // The paper's setup: a 249x251 image, so T_7 of the 20-vertex mesh has ~3.5 samples a pixel.
    const int W = 249, H = 251;
    std::printf("tesswave demo -> %s\n", dir.string().c_str());

    prepare_folder((dir / "samples").string(), true);
    for (const auto& f : write_samples((dir / "samples").string(), W, H)) {
        demo.written.push_back(f);
    }
    const std::string scene_path = (dir / "samples" / "scene.png").string();
    const Image scene = read_input(scene_path);

    std::mt19937_64 rng(7);
    std::vector<Vec2> points;
    std::string point_text = "# 40 random points for the triangulation sample (x y, pixels)\n";
    for (int i = 0; i < 40; ++i) {
        const Vec2 q{8 + (W - 16) * ((rng() >> 11) * 0x1.0p-53),
                     8 + (H - 16) * ((rng() >> 11) * 0x1.0p-53)};
        points.push_back(q);
        point_text += str(q.x, " ", q.y, "\n");
    }
    write_file_atomic(demo.out("points.txt"), point_text);

    const std::pair<std::string, Mesh> meshes[] = {
        {"paper_t0", samples::paper_t0(W, H)},
        {"paper_features", samples::paper_t0_with_features(W, H)},
        {"grid", grid_mesh(W, H, 8, 6)},
        {"voronoi", voronoi_mesh(W, H, {.sites = 48, .seed = 3, .lloyd_iterations = 2})},
        {"triangulation", triangulate_points(W, H, points, {.border_points_per_side = 2})},
    };
    std::printf("\n%-16s %8s %6s %8s %12s  %s\n", "mesh", "vertices", "faces", "features", "|V_7|",
                "valid");
    nlohmann::json report = {{"meshes", nlohmann::json::array()}};
    for (const auto& [name, mesh] : meshes) {
        const ValidationReport v = validate(mesh);
        write_mesh(mesh, demo.out(name + ".json"));
        const int64_t v7 = level_counts(mesh, 7).back().vertices;
        std::printf("%-16s %8d %6d %8zu %12lld  %s\n", name.c_str(), mesh.num_vertices(),
                    mesh.num_faces(), mesh.features.size(), static_cast<long long>(v7),
                    v.ok() ? "yes" : v.problems.front().c_str());
        if (!v.ok()) throw Error(name + ": generated an invalid mesh: " + v.problems.front());
        write_image(draw_mesh(mesh, {.levels = 2, .scale = 2.0}, &scene), demo.out(name + ".png"));
        report["meshes"].push_back({{"name", name},
                                    {"vertices", mesh.num_vertices()},
                                    {"faces", mesh.num_faces()},
                                    {"vertices_level_7", v7}});
    }
    write_file_atomic(demo.out("paper_t0.svg"),
                      draw_mesh_svg(meshes[0].second, {.levels = 3}, "samples/scene.png"));

    std::printf(
        "\nlifted bilinear wavelet transform, paper setup (T0: 20 vertices, 14 faces, J=7) "
        "on scene.png:\n");
    const nlohmann::json t = transform_report(meshes[0].second, scene);
    std::printf("  samples                %d (%.2f per pixel; the paper: 217921, ~3.5)\n",
                t["samples"].get<int>(), t["samples_per_pixel"].get<double>());
    std::printf("  build / forward / inverse  %.3f / %.3f / %.3f s (3 channels)\n",
                t["build_seconds"].get<double>(), t["forward_seconds"].get<double>(),
                t["inverse_seconds"].get<double>());
    std::printf("  details below 1/2 grey level  %.1f %%\n",
                100 * t["details_below_half_a_grey_level"].get<double>());
    std::printf("  float round trip max error    %.2e\n",
                t["float_round_trip_max_error"].get<double>());
    std::printf("  integer round trip            %s\n",
                t["integer_round_trip_exact"].get<bool>() ? "bit-exact" : "NOT EXACT");
    std::printf("  linear ramp, largest detail   %.2e (linear precision)\n",
                t["ramp_max_detail"].get<double>());
    report["transform"] = t;
    write_file_atomic(demo.out("report.json"), report.dump(2) + "\n");

    std::printf(
        "\nanalyze: the paper's Figure 7 experiment on %s (T0 of 20 vertices, 14 faces; "
        "density 3.5 -> J=7), beside fixed-grid wavelets:\n",
        scene_path.c_str());
    AnalyzeRequest request;
    request.image = scene_path;
    request.output = (dir / "analyze").string();
    request.overwrite = true;
    print_analysis_table(run_analyze(request));
    demo.written.push_back(request.output +
                           "/ (resampled, coefficients, mesh, reconstructions, "
                           "report.json)");

    codec_demo(scene, demo);
    morph_demo(demo);
    for (const auto& f : video_demo((dir / "samples" / "clip.mkv").string(), dir.string())) {
        demo.written.push_back(f);
    }

    std::printf("\noutputs:\n");
    for (const auto& f : demo.written) std::printf("  %s\n", f.c_str());
}

}  // namespace

void add_demo_command(CLI::App& app) {
    struct Args {
        std::string dir = "tesswave-demo";
        bool overwrite = false;
    };
    auto args = std::make_shared<Args>();
    auto* cmd = app.add_subcommand(
        "demo",
        "Generate the built-in samples and run every job on them (prints where outputs go)");
    cmd->add_option("-o,--output", args->dir, "Output folder")->capture_default_str();
    cmd->add_flag("-y,--overwrite", args->overwrite, "Overwrite files in a non-empty folder");
    cmd->callback([args] { run_demo(args->dir, args->overwrite); });
}

}  // namespace tesswave::cli
