// tesswave compare: the still codec beside itself on the fixed grid and beside JPEG 2000, at
// equal file sizes, with CSV, a summary table, rate-distortion plots and side-by-side crops.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.h"
#include "core/codec/still_codec.h"
#include "core/eval/contact_sheet.h"
#include "core/eval/peer_jpeg2000.h"
#include "core/eval/plot.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/math/error.h"
#include "core/math/metrics.h"
#include "core/math/project.h"
#include "core/math/strings.h"

namespace fs = std::filesystem;

namespace tesswave::cli {
namespace {

struct CompareArgs {
    std::vector<std::string> images;
    std::vector<double> bpp = {0.25, 0.5, 1, 2};
    std::string output;
    double density = kStillDensity;
    std::string sampling = "fit";
    bool overwrite = false, json = false;
};

struct Row {
    std::string image, method;
    double target_bpp = 0, bpp = 0;
    int64_t bytes = 0;
    double psnr = 0, ssim = 0, encode_s = 0, decode_s = 0;
    double mpixels = 0;
};

const char* const kMethods[] = {"mesh", "mesh aligned", "grid 5/3", "grid 9/7", "JPEG 2000"};

StillOptions method_options(int method, double density, const std::string& sampling) {
    StillOptions o;
    o.sampling = sampling_from_name(sampling);
    o.measure = false;
    o.density = density;
    if (method == 1) o.aligned = true;
    if (method == 2) o.transform = TwiTransform::grid53;
    if (method == 3) o.transform = TwiTransform::grid97;
    return o;
}

// Encodes with one of our methods (method < 4) or JPEG 2000 into `budget` bytes (0: lossless),
// decodes, and measures.
Row run_method(const Image& image, int method, int64_t budget, double density,
               const std::string& sampling, Image* decoded) {
    Row row;
    row.method = kMethods[method];
    const double pixels = double(image.width) * image.height;
    auto start = std::chrono::steady_clock::now();
    std::vector<uint8_t> file;
    if (method == 4) {
        file = encode_jpeg2000(image, {.target_bytes = budget});
    } else {
        StillOptions o = method_options(method, density, sampling);
        o.lossless = budget == 0;
        o.max_bytes = budget;
        file = compress_image(image, o).file;
    }
    row.encode_s = seconds_since(start);
    start = std::chrono::steady_clock::now();
    Image out = method == 4 ? decode_jpeg2000(file) : decompress_image(file, row.method);
    row.decode_s = seconds_since(start);
    row.bytes = static_cast<int64_t>(file.size());
    row.bpp = row.bytes * 8.0 / pixels;
    row.mpixels = pixels / 1e6;
    row.psnr = psnr(image, out).all;
    row.ssim = ssim(image, out).all;
    if (decoded) *decoded = std::move(out);
    return row;
}

nlohmann::json to_json(const Row& r) {
    return {{"image", r.image}, {"method", r.method},     {"target_bpp", r.target_bpp},
            {"bytes", r.bytes}, {"bpp", r.bpp},           {"psnr", r.psnr},
            {"ssim", r.ssim},   {"encode_s", r.encode_s}, {"decode_s", r.decode_s}};
}

std::string csv(const std::vector<Row>& rows) {
    std::string out = "image,method,target_bpp,bytes,bpp,psnr,ssim,encode_s,decode_s\n";
    for (const Row& r : rows) {
        out += str(r.image, ",", r.method, ",", r.target_bpp, ",", r.bytes, ",", r.bpp, ",",
                   std::isinf(r.psnr) ? std::string("inf") : str(r.psnr), ",", r.ssim, ",",
                   r.encode_s, ",", r.decode_s, "\n");
    }
    return out;
}

void write_plot(const std::vector<Row>& rows, const std::string& title, const std::string& path) {
    std::vector<PlotSeries> series;
    for (const char* m : kMethods) {
        PlotSeries s{m, {}, {}};
        for (const Row& r : rows) {
            if (r.method == m) {
                s.x.push_back(r.bpp);
                s.y.push_back(r.psnr);
            }
        }
        series.push_back(std::move(s));
    }
    write_image(draw_line_plot(series, {.title = title,
                                        .x_label = "bits per pixel",
                                        .y_label = "PSNR (dB), all channels",
                                        .log_x = true}),
                path);
}

// Means over the images per method and target rate.
std::vector<Row> averages(const std::vector<Row>& rows) {
    std::map<std::pair<std::string, double>, std::pair<Row, int>> sums;
    for (const Row& r : rows) {
        auto& [sum, n] = sums[{r.method, r.target_bpp}];
        sum.image = "average";
        sum.method = r.method;
        sum.target_bpp = r.target_bpp;
        sum.bytes += r.bytes;
        sum.bpp += r.bpp;
        sum.psnr += r.psnr;
        sum.ssim += r.ssim;
        sum.encode_s += r.encode_s;
        sum.decode_s += r.decode_s;
        sum.mpixels += r.mpixels;
        ++n;
    }
    std::vector<Row> out;
    for (const char* m : kMethods) {
        for (auto& [key, value] : sums) {
            if (key.first != m) continue;
            Row r = value.first;
            const int n = value.second;
            r.bytes /= n;
            r.bpp /= n;
            r.psnr /= n;
            r.ssim /= n;
            out.push_back(r);
        }
    }
    return out;
}

std::string summary(const std::vector<Row>& avg, const std::vector<Row>& lossless,
                    const std::vector<Row>& resample) {
    std::string s = "Lossy, averages over the images (equal file sizes per image and rate):\n";
    s += str("  rate    method          bpp     PSNR dB   vs J2K   SSIM     enc MP/s  dec MP/s\n");
    std::map<double, double> j2k;
    for (const Row& r : avg) {
        if (r.method == "JPEG 2000") j2k[r.target_bpp] = r.psnr;
    }
    char line[256];
    for (const Row& r : avg) {
        std::snprintf(line, sizeof line,
                      "  %-6g  %-14s %6.4f  %7.2f  %+7.2f  %7.4f  %8.2f  %8.2f\n", r.target_bpp,
                      r.method.c_str(), r.bpp, r.psnr, r.psnr - j2k[r.target_bpp], r.ssim,
                      r.mpixels / r.encode_s, r.mpixels / r.decode_s);
        s += line;
    }
    s += "Resampling loss of the mesh (lossless mesh samples rendered back):\n";
    for (const Row& r : resample) {
        std::snprintf(line, sizeof line, "  %-24s %7.2f dB  (%s)\n", r.image.c_str(), r.psnr,
                      r.method.c_str());
        s += line;
    }
    s += "Lossless bits per pixel:\n";
    for (const Row& r : lossless) {
        std::snprintf(line, sizeof line, "  %-24s %-14s %7.3f bpp  enc %.3f s  dec %.3f s\n",
                      r.image.c_str(), r.method.c_str(), r.bpp, r.encode_s, r.decode_s);
        s += line;
    }
    return s;
}

void run_compare(const CompareArgs& a) {
    const std::vector<double>& rates = a.bpp;
    check_folder(a.output, a.overwrite, a.images);
    std::vector<Image> images;
    for (const std::string& path : a.images) {
        Image image = read_input(path);
        if (image.format != SampleFormat::u8) {
            throw Error(str(path, ": compare works on 8-bit images (JPEG 2000 peer is 8-bit)"));
        }
        if (image.width < 8 || image.height < 8) {
            throw Error(str(path, ": ", image.width, "x", image.height,
                            " pixels; compare measures SSIM, which needs at least 8x8"));
        }
        images.push_back(std::move(image));
    }
    prepare_folder(a.output, a.overwrite, a.images);
    const fs::path dir(a.output);
    std::vector<Row> rows, lossless, resample;
    ProgressBar bar;
    const double steps = double(images.size()) * (rates.size() + 1);
    double done = 0;
    for (size_t i = 0; i < images.size(); ++i) {
        const Image& image = images[i];
        const std::string name = fs::path(a.images[i]).filename().string();
        const std::string stem = fs::path(a.images[i]).stem().string();
        bar.update(done / steps, "lossless");
        for (int m : {1, 2, 4}) {
            Row r = run_method(image, m, 0, a.density, a.sampling, nullptr);
            r.image = name;
            lossless.push_back(r);
        }
        {
            Row png;
            png.image = name;
            png.method = "PNG";
            const std::string tmp = temporary_name((dir / "lossless.png").string());
            const auto start = std::chrono::steady_clock::now();
            write_image(image, tmp);
            png.encode_s = seconds_since(start);
            png.bytes = static_cast<int64_t>(fs::file_size(tmp));
            discard_temporary(tmp);
            png.bpp = png.bytes * 8.0 / (double(image.width) * image.height);
            lossless.push_back(png);
        }
        StillOptions lo = method_options(0, a.density, a.sampling);
        lo.lossless = true;
        lo.measure = true;
        Row rs;
        rs.image = name;
        rs.psnr = compress_image(image, lo).psnr;
        rs.method = str("grid mesh, density ", a.density);
        resample.push_back(rs);
        done += 1;
        std::vector<Row> image_rows;
        for (double rate : rates) {
            bar.update(done / steps, "lossy");
            // At least a byte: a budget of 0 would mean lossless to every coder.
            const int64_t budget = std::max<int64_t>(
                1, static_cast<int64_t>(std::floor(rate * image.width * image.height / 8)));
            // JPEG 2000 first: it can only approach the budget from below; ours then match it.
            std::vector<Image> crops = {centre_crop(image, 256, 256)};
            std::vector<std::string> captions = {"original"};
            Image decoded;
            std::vector<Row> at_rate;
            Row j2k;
            try {
                j2k = run_method(image, 4, budget, a.density, a.sampling, &decoded);
                for (int m = 0; m < 4; ++m) {
                    Image ours;
                    at_rate.push_back(
                        run_method(image, m, j2k.bytes, a.density, a.sampling, &ours));
                    crops.push_back(centre_crop(ours, 256, 256));
                    captions.push_back(
                        str(kMethods[m], " ", std::lround(at_rate.back().psnr * 100) / 100.0));
                }
            } catch (const Error& e) {
                throw Error(
                    str(a.images[i], ": --bpp ", rate, " (", budget, " bytes): ", e.what()));
            }
            at_rate.push_back(j2k);
            crops.push_back(centre_crop(decoded, 256, 256));
            captions.push_back(str("JPEG 2000 ", std::lround(j2k.psnr * 100) / 100.0));
            for (Row& r : at_rate) {
                r.image = name;
                r.target_bpp = rate;
                image_rows.push_back(r);
            }
            write_image(contact_sheet(crops, captions, {.columns = 3}),
                        (dir / str("crops_", stem, "_", rate, "bpp.png")).string());
            done += 1;
        }
        write_plot(image_rows, name, (dir / str("rd_", stem, ".png")).string());
        rows.insert(rows.end(), image_rows.begin(), image_rows.end());
    }
    bar.update(1.0, "writing");
    const std::vector<Row> avg = averages(rows);
    write_plot(avg, str("average of ", images.size(), " images"),
               (dir / "rd_average.png").string());
    write_file_atomic((dir / "compare.csv").string(), csv(rows));
    write_file_atomic((dir / "lossless.csv").string(), csv(lossless));
    const std::string text = summary(avg, lossless, resample);
    write_file_atomic((dir / "summary.txt").string(), text);
    nlohmann::json j = {{"rows", nlohmann::json::array()},
                        {"average", nlohmann::json::array()},
                        {"lossless", nlohmann::json::array()},
                        {"resample", nlohmann::json::array()}};
    for (const Row& r : rows) j["rows"].push_back(to_json(r));
    for (const Row& r : avg) j["average"].push_back(to_json(r));
    for (const Row& r : lossless) j["lossless"].push_back(to_json(r));
    for (const Row& r : resample) j["resample"].push_back(to_json(r));
    write_file_atomic((dir / "compare.json").string(), j.dump(2));
    bar.clear();
    if (a.json) {
        std::printf("%s\n", j.dump(2).c_str());
    } else {
        std::printf("%soutputs in %s\n", text.c_str(), a.output.c_str());
    }
}

}  // namespace

void add_compare_command(CLI::App& app) {
    auto a = std::make_shared<CompareArgs>();
    CLI::App* cmd = app.add_subcommand(
        "compare", "Mesh wavelets vs fixed-grid 5/3 and 9/7 vs JPEG 2000 at equal file sizes");
    cmd->add_option("images", a->images, "Input images (8-bit)")->required();
    cmd->add_option("--bpp", a->bpp, "Rates in bits per pixel, comma-separated")
        ->delimiter(',')
        ->check(CLI::Range(1e-6, 64.0))
        ->capture_default_str();
    cmd->add_option("--density", a->density, "Samples per pixel of the mesh path's grid mesh")
        ->capture_default_str()
        ->check(density_range());
    cmd->add_option("-o,--output", a->output, "Output folder")->required();
    add_sampling_option(cmd, a->sampling);
    cmd->add_flag("-y,--overwrite", a->overwrite, "Overwrite files in a non-empty folder");
    cmd->add_flag("--json", a->json, "Print the results as JSON");
    cmd->callback([a] { run_compare(*a); });
}

}  // namespace tesswave::cli
