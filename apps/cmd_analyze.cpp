// tesswave analyze: the paper's Figure 7 experiment on any image, beside fixed-grid wavelets.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.h"
#include "core/eval/analysis.h"
#include "core/eval/mesh_draw.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/io/mesh_io.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/project.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"
#include "core/math/validate.h"
#include "core/math/voronoi.h"
#include "samples/sample_meshes.h"

namespace tesswave::cli {
namespace {

namespace fs = std::filesystem;

std::string keep_name(double k) {
    std::ostringstream s;
    s.precision(3);
    s << k;
    return s.str();
}

nlohmann::json report_json(const AnalyzeRequest& request, const Image& image,
                           const AnalysisResult& r) {
    nlohmann::json rows = nlohmann::json::array();
    for (const auto& row : r.rows) {
        rows.push_back(
            {{"method", row.method},
             {"keep_percent", row.keep_percent},
             {"kept", row.kept},
             {"total", row.total},
             {"psnr", std::isfinite(row.psnr) ? nlohmann::json(row.psnr) : nlohmann::json("inf")},
             {"ssim", row.ssim}});
    }
    return {{"image", request.image},
            {"width", image.width},
            {"height", image.height},
            {"channels", image.channels()},
            {"mesh", request.mesh_description},
            {"levels", r.levels},
            {"samples", r.samples},
            {"samples_per_pixel", r.samples_per_pixel},
            {"sampling", request.sampling},
            {"projection_iterations", r.projection_iterations},
            {"rows", rows}};
}

}  // namespace

void print_analysis_table(const AnalysisResult& r) {
    std::printf("%-12s %8s %12s %10s %8s\n", "method", "keep %", "kept", "PSNR dB", "SSIM");
    for (const auto& row : r.rows) {
        std::printf("%-12s %8s %12lld %10.2f %8.4f\n", row.method.c_str(),
                    keep_name(row.keep_percent).c_str(), static_cast<long long>(row.kept), row.psnr,
                    row.ssim);
    }
}

Mesh analysis_mesh(const AnalyzeRequest& request, const Image& image, std::string& description) {
    const double W = image.width, H = image.height;
    Mesh mesh;
    if (!request.mesh.empty()) {
        mesh = mesh_for(request.mesh, request.image, image, request.fit_mesh);
        description = request.mesh;
    } else {
        mesh = samples::paper_t0(W, H);
        description = "paper T0 (20 vertices, 14 faces)";
    }
    return mesh;
}

AnalysisResult run_analyze(const AnalyzeRequest& request) {
    // Inputs and options are checked, and the work done, before the folder is created: a failed
    // run leaves nothing behind.
    check_folder(request.output, request.overwrite, {request.image, request.mesh});
    const Image image = read_input(request.image);
    AnalyzeRequest req = request;
    const Mesh mesh = analysis_mesh(request, image, req.mesh_description);
    AnalysisOptions options;
    options.keep = request.keep;
    options.picture_rule = request.select == "l2" ? SelectionRule::l2 : SelectionRule::paper;
    options.sampling = sampling_from_name(request.sampling);
    options.levels = request.levels > 0
                         ? request.levels
                         : level_for_density(mesh, image.width * image.height, request.density);
    ProgressBar bar;
    options.progress = [&](double done, const char* stage) { bar.update(done, stage); };
    AnalysisResult r;
    try {
        r = analyze_image(image, mesh, options);
    } catch (const Error& e) {
        throw Error(str(request.image, ": ", e.what()));
    }

    prepare_folder(request.output, request.overwrite, {request.image, request.mesh});
    const fs::path dir(request.output);
    write_image(r.resampled, (dir / "resampled.png").string());
    write_image(r.coefficients, (dir / "coefficients.png").string());
    const double scale = std::max(1.0, 600.0 / std::max(image.width, image.height));
    // Up to three levels, fewer where they would be a flat colour (a million-cell mesh drew none
    // after 70 s of analysis: the picture was refused and the run failed).
    const int drawn = drawable_levels(mesh, std::min(3, r.levels), std::round(scale));
    write_image(draw_mesh(mesh, {.levels = drawn, .scale = std::round(scale)}, &image),
                (dir / "mesh.png").string());
    const std::vector<double> keep = options.keep;
    for (size_t k = 0; k < keep.size(); ++k) {
        const std::string tag = keep_name(keep[k]);
        write_image(r.mesh_images[k], (dir / ("mesh_keep_" + tag + ".png")).string());
        write_image(r.grid53_images[k], (dir / ("grid53_keep_" + tag + ".png")).string());
        write_image(r.grid97_images[k], (dir / ("grid97_keep_" + tag + ".png")).string());
    }
    write_file_atomic((dir / "report.json").string(), report_json(req, image, r).dump(2) + "\n");
    return r;
}

void add_analyze_command(CLI::App& app) {
    struct Args {
        AnalyzeRequest request;
        bool json = false;
    };
    auto args = std::make_shared<Args>();
    AnalyzeRequest& q = args->request;
    auto* cmd = app.add_subcommand(
        "analyze",
        "Put an image on a tessellation, transform it, and reconstruct it from k % of its "
        "wavelet coefficients, beside fixed-grid 5/3 and 9/7 (the paper's Figure 7)");
    cmd->add_option("image", q.image, "Image file (PNG, JPEG, TIFF, EXR, PNM, ...)")->required();
    cmd->add_option("--mesh", q.mesh,
                    "Tessellation: a .json file, grid[:CxR] or voronoi[:N] (default: the paper's "
                    "20-vertex T0)");
    cmd->add_flag("--fit-mesh", q.fit_mesh, "Scale a --mesh whose domain differs from the image");
    auto* levels =
        cmd->add_option("-J,--levels", q.levels, "Finest level J")->check(CLI::Range(1, 12));
    auto* density =
        cmd->add_option("--density", q.density, "Choose J for about this many samples per pixel")
            ->capture_default_str()
            ->check(density_range());
    levels->excludes(density);
    cmd->add_option("--keep", q.keep,
                    "Percentages of detail coefficients to keep (comma-separated)")
        ->delimiter(',')
        ->capture_default_str()
        ->check(CLI::Range(1e-9, 100.0));
    cmd->add_option("--select", q.select, "Rule of the reconstructions written: paper or l2")
        ->capture_default_str()
        ->check(CLI::IsMember({"paper", "l2"}));
    add_sampling_option(cmd, q.sampling);
    cmd->add_option("-o,--output", q.output, "Output folder")->required();
    cmd->add_flag("-y,--overwrite", q.overwrite, "Overwrite files in a non-empty folder");
    cmd->add_flag("--json", args->json, "Print the report as JSON instead of a table");
    cmd->callback([args] {
        const AnalysisResult r = run_analyze(args->request);
        if (args->json) {
            std::printf(
                "%s\n",
                read_file((fs::path(args->request.output) / "report.json").string()).c_str());
            return;
        }
        std::printf("%s: J=%d, %lld samples (%.2f per pixel), %s sampling",
                    args->request.image.c_str(), r.levels, static_cast<long long>(r.samples),
                    r.samples_per_pixel, args->request.sampling.c_str());
        if (args->request.sampling == "fit") {
            std::printf(" (%d iterations)", r.projection_iterations);
        }
        std::printf("\n");
        print_analysis_table(r);
        std::printf("outputs in %s\n", args->request.output.c_str());
    });
}

}  // namespace tesswave::cli
