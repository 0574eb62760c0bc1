// tesswave compress / decompress: the .twi still-image codec.
#include <chrono>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "core/codec/still_codec.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/math/error.h"
#include "core/math/project.h"
#include "core/math/strings.h"

namespace tesswave::cli {
namespace {

TwiTransform parse_grid(const std::string& grid) {
    if (grid.empty()) return TwiTransform::mesh;
    return grid == "97" ? TwiTransform::grid97 : TwiTransform::grid53;
}

struct CompressArgs {
    std::string input, output, mesh, grid, sampling = "fit", mesh_wavelet = "97";
    double bpp = 0, psnr = 0, density = kStillDensity;
    bool lossless = false, aligned = false, fit_mesh = false, overwrite = false, json = false;
    int levels = 0;
};

// Without a rate option: every coefficient quantized with the step whose error alone is about this
// many dB, and the whole stream kept. Every transform and mesh reaches it (unlike a PSNR target,
// which a coarse mesh may never reach): the grid wavelets land near 40 dB, a mesh at its
// resampling ceiling.
constexpr double kDefaultQualityDb = 40;

// --lossless must give the image back bit for bit. A mesh does so only when its finest vertices
// are the pixel centres (the aligned mesh): the default grid mesh is swapped for it, with a note;
// a mesh file is refused, since its samples are not the pixels.
void choose_lossless_mesh(CompressArgs& a) {
    if (!a.lossless) return;
    if (a.grid == "97") {
        throw CLI::ValidationError("--lossless", "the 9/7 is not reversible (use --grid 53)");
    }
    if (!a.grid.empty() || a.aligned) return;
    if (!a.mesh.empty()) {
        throw CLI::ValidationError(
            "--lossless",
            str("a --mesh file cannot be lossless: its samples are not the pixels, "
                "so the image cannot come back exactly (use --aligned or --grid 53)"));
    }
    a.aligned = true;
    warn(
        "note: --lossless uses the aligned mesh (its finest vertices are the pixel centres), the "
        "only mesh that gives the image back exactly");
}

void run_compress(CompressArgs a) {
    check_output(a.output, a.overwrite, {a.input});
    choose_lossless_mesh(a);
    const auto start = std::chrono::steady_clock::now();
    StillOptions o{.transform = parse_grid(a.grid), .lossless = a.lossless};
    if (a.psnr > 0) o.target_psnr = a.psnr;
    if (a.bpp <= 0 && a.psnr <= 0 && !a.lossless) o.base_step = step_for_psnr(kDefaultQualityDb);
    o.aligned = a.aligned;
    o.levels = a.levels;
    o.density = a.density;
    o.sampling = sampling_from_name(a.sampling);
    o.mesh_wavelet = mesh_wavelet_from_name(a.mesh_wavelet);
    // A size the codec would refuse (a mesh of too many samples) is refused from the file's
    // header, before its pixels are read; a mesh file is checked once it is read.
    ImageLimits limits;
    if (a.mesh.empty()) {
        limits.check_size = [&o](int width, int height, int channels) {
            check_still_size(width, height, channels, o);
        };
    }
    const Image image = read_input(a.input, limits);
    const double pixels = double(image.width) * image.height;
    // At least a byte: a budget of 0 means no budget (the whole stream).
    if (a.bpp > 0)
        o.max_bytes = std::max<int64_t>(1, static_cast<int64_t>(std::floor(a.bpp * pixels / 8)));
    if (!a.mesh.empty()) o.mesh = mesh_for(a.mesh, a.input, image, a.fit_mesh);
    ProgressBar bar;
    o.progress = [&bar](double done, const char* stage) { bar.update(done, stage); };
    StillResult r;
    try {
        r = compress_image(image, o);
    } catch (const Error& e) {
        throw Error(str(a.input, ": ", e.what()));
    }
    if (!r.target_reached) {
        char line[160];
        std::snprintf(line, sizeof line,
                      "%.2f dB is out of reach; writing the whole stream, %.2f dB", a.psnr, r.psnr);
        warn(str("warning: ", a.input, ": ", line,
                 r.header.transform == TwiTransform::mesh
                     ? " (the mesh's resampling caps it: a denser mesh, --density or --grid goes "
                       "higher)"
                     : ""));
    }
    write_file_atomic(
        a.output, std::string_view(reinterpret_cast<const char*>(r.file.data()), r.file.size()));
    bar.clear();
    const double seconds = seconds_since(start);
    const double bpp = r.file.size() * 8.0 / pixels;
    nlohmann::json j = {{"input", a.input},
                        {"output", a.output},
                        {"width", image.width},
                        {"height", image.height},
                        {"channels", image.channels()},
                        {"transform", transform_name(r.header.transform)},
                        {"lossless", r.header.lossless},
                        {"levels", r.header.levels},
                        {"bytes", r.file.size()},
                        {"header_bytes", r.header.header_bytes},
                        {"bpp", bpp},
                        {"psnr", r.psnr},
                        {"target_reached", r.target_reached},
                        {"sampling", r.sampling},
                        {"seconds", seconds}};
    if (a.json) {
        std::printf("%s\n", j.dump(2).c_str());
        return;
    }
    const std::string sampling =
        r.header.transform == TwiTransform::mesh && !r.header.lossless ? r.sampling + ", " : "";
    std::printf("%s -> %s: %zu bytes, %.4f bpp, PSNR %.2f dB (%s, %s%sJ=%d), %.2f s\n",
                a.input.c_str(), a.output.c_str(), r.file.size(), bpp, r.psnr,
                transform_name(r.header.transform), r.header.lossless ? "lossless, " : "",
                sampling.c_str(), r.header.levels, seconds);
}

struct DecompressArgs {
    std::string input, output;
    int64_t bytes = 0, max_pixels = 0;
    double fraction = 0;
    bool overwrite = false, json = false;
};

void run_decompress(const DecompressArgs& a) {
    check_output(a.output, a.overwrite, {a.input});
    const std::string data = read_file(a.input);
    const std::span<const uint8_t> file(reinterpret_cast<const uint8_t*>(data.data()), data.size());
    StillDecodeOptions o{.limits = limits_for<TwiLimits>(a.max_pixels)};
    if (a.bytes > 0) o.max_bytes = static_cast<size_t>(a.bytes);
    if (a.fraction > 0) o.max_bytes = static_cast<size_t>(std::ceil(a.fraction * data.size()));
    const Image image = decompress_image(file, a.input, o);
    write_image(image, a.output);
    const size_t used = std::min(o.max_bytes, data.size());
    const double bpp = used * 8.0 / (double(image.width) * image.height);
    if (a.json) {
        std::printf("%s\n", nlohmann::json{{"input", a.input},
                                           {"output", a.output},
                                           {"width", image.width},
                                           {"height", image.height},
                                           {"channels", image.channels()},
                                           {"bytes_decoded", used},
                                           {"bytes_in_file", data.size()},
                                           {"bpp", bpp}}
                                .dump(2)
                                .c_str());
        return;
    }
    std::printf("%s -> %s: %dx%d, %zu of %zu bytes decoded (%.4f bpp)\n", a.input.c_str(),
                a.output.c_str(), image.width, image.height, used, data.size(), bpp);
}

}  // namespace

void add_codec_commands(CLI::App& app) {
    auto c = std::make_shared<CompressArgs>();
    CLI::App* cmd = app.add_subcommand("compress", "Compress an image to .twi (mesh wavelets)");
    cmd->add_option("image", c->input, "Input image (PNG, JPEG, TIFF, ...)")->required();
    cmd->add_option("-o,--output", c->output, "Output .twi file")
        ->required()
        ->check(output_extension({".twi"}, "compress", "a .twi file"));
    auto* bpp = cmd->add_option("--bpp", c->bpp, "Exact budget in bits per pixel (file size)")
                    ->check(positive("a number of bits per pixel"));
    auto* psnr = cmd->add_option("--psnr", c->psnr,
                                 "Smallest file reaching this PSNR in dB (out of reach: a "
                                 "warning and the whole stream). Without --bpp, --psnr or "
                                 "--lossless, every coefficient is kept at a 40 dB step")
                     ->check(CLI::Range(1.0, 200.0));
    auto* lossless = cmd->add_flag("--lossless", c->lossless,
                                   "Bit-exact: integer lifting, every bit-plane coded; the "
                                   "aligned mesh unless --grid 53 (a --mesh file is refused)");
    bpp->excludes(psnr)->excludes(lossless);
    psnr->excludes(lossless);
    auto* grid = cmd->add_option("--grid", c->grid, "Fixed-grid wavelet on the pixels: 53 or 97")
                     ->check(CLI::IsMember({"53", "97"}));
    auto* mesh = cmd->add_option("--mesh", c->mesh,
                                 "Tessellation: a .json file, grid[:CxR] or voronoi[:N] (default: "
                                 "a grid at --density)");
    auto* fit_mesh = cmd->add_flag("--fit-mesh", c->fit_mesh,
                                   "Scale a --mesh whose domain differs from the image");
    auto* aligned = cmd->add_flag("--aligned", c->aligned,
                                  "Grid mesh with its finest vertices on the pixel centres "
                                  "(width-1 and height-1 multiples of 2^J): exact sampling");
    grid->excludes(mesh)->excludes(aligned);
    mesh->excludes(aligned);
    cmd->add_option("-J,--levels", c->levels, "Mesh level J, or fixed-grid levels")
        ->check(CLI::Range(1, 12));
    auto* density =
        cmd->add_option("--density", c->density, "Mesh samples per pixel when J is chosen")
            ->capture_default_str()
            ->check(density_range());
    // Options of the mesh path have no meaning on the fixed grid: refused with it.
    grid->excludes(density)
        ->excludes(fit_mesh)
        ->excludes(add_sampling_option(cmd, c->sampling))
        ->excludes(add_mesh_wavelet_option(*cmd, c->mesh_wavelet));
    cmd->add_flag("-y,--overwrite", c->overwrite, "Overwrite the output");
    cmd->add_flag("--json", c->json, "Print the result as JSON");
    cmd->callback([c] { run_compress(*c); });

    auto d = std::make_shared<DecompressArgs>();
    cmd = app.add_subcommand("decompress", "Decode a .twi file, or a prefix of it, to an image");
    cmd->add_option("input", d->input, "Input .twi file")->required();
    cmd->add_option("-o,--output", d->output, "Output image (PNG, TIFF, ...)")
        ->required()
        ->check(image_output());
    auto* bytes = cmd->add_option("--bytes", d->bytes, "Decode only the first N bytes")
                      ->check(positive("a number of bytes"));
    auto* fraction = cmd->add_option("--fraction", d->fraction, "Decode only this fraction")
                         ->check(CLI::Range(0.0, 1.0) & positive("a fraction"));
    bytes->excludes(fraction);
    add_max_pixels_option(cmd, d->max_pixels);
    cmd->add_flag("-y,--overwrite", d->overwrite, "Overwrite the output");
    cmd->add_flag("--json", d->json, "Print the result as JSON");
    cmd->callback([d] { run_decompress(*d); });
}

}  // namespace tesswave::cli
