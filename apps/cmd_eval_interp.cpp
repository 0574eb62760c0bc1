// tesswave eval-interp: in-between frames against the truth, for frame triplets (frame0/1/2,
// frame1 the truth) and the Middlebury layout (frame10, frame11, truth frame10i11): cross-dissolve,
// warp + dissolve (linear), our band schedules, and FFmpeg's minterpolate, all in one run.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "core/eval/contact_sheet.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/io/video_io.h"
#include "core/math/error.h"
#include "core/math/metrics.h"
#include "core/math/strings.h"
#include "morph/inbetween.h"

namespace fs = std::filesystem;

namespace tesswave::cli {
namespace {

struct Sequence {
    std::string name, f0, f1, truth;
};

// The frames of one folder, by either layout (Error naming the folder otherwise).
Sequence find_sequence(const fs::path& dir) {
    const std::string name =
        dir.filename().empty() ? dir.parent_path().filename().string() : dir.filename().string();
    if (fs::exists(dir / "frame0.png") && fs::exists(dir / "frame1.png") &&
        fs::exists(dir / "frame2.png")) {
        return {name, (dir / "frame0.png").string(), (dir / "frame2.png").string(),
                (dir / "frame1.png").string()};
    }
    if (fs::exists(dir / "frame10.png") && fs::exists(dir / "frame11.png") &&
        fs::exists(dir / "frame10i11.png")) {
        return {name, (dir / "frame10.png").string(), (dir / "frame11.png").string(),
                (dir / "frame10i11.png").string()};
    }
    throw Error(
        str(dir.string(), ": no frame0/1/2.png triplet and no frame10, frame11, frame10i11"));
}

// Folders given, or their subfolders when a folder holds sequences rather than frames.
std::vector<Sequence> sequences(const std::vector<std::string>& dirs) {
    std::vector<Sequence> out;
    for (const std::string& d : dirs) {
        if (!fs::is_directory(d)) throw Error(str(d, ": not a folder"));
        try {
            out.push_back(find_sequence(d));
        } catch (const Error&) {
            std::vector<fs::path> subs;
            for (const auto& e : fs::directory_iterator(d)) {
                if (e.is_directory()) subs.push_back(e.path());
            }
            std::sort(subs.begin(), subs.end());
            if (subs.empty()) throw;
            for (const fs::path& s : subs) out.push_back(find_sequence(s));
        }
    }
    return out;
}

Image dissolve(const Image& a, const Image& b) {
    Image out = a;
    for (int c = 0; c < out.channels(); ++c) {
        for (size_t i = 0; i < out.planes[c].size(); ++i) {
            out.planes[c][i] = 0.5f * (a.planes[c][i] + b.planes[c][i]);
        }
    }
    return out;
}

// |test - truth| x 4, grey.
Image error_map(const Image& test, const Image& truth) {
    Image out = make_image(truth.width, truth.height, 1);
    for (size_t i = 0; i < out.planes[0].size(); ++i) {
        float e = 0;
        for (int c = 0; c < std::min(3, truth.channels()); ++c) {
            e = std::max(e, std::abs(test.planes[c][i] - truth.planes[c][i]));
        }
        out.planes[0][i] = std::min(1.0f, 4 * e);
    }
    return out;
}

Image rgb(Image image) {
    while (image.channels() < 3) image.planes.push_back(image.planes[0]);
    image.planes.resize(3);
    return image;
}

// "inbetween" is `tesswave inbetween`: linear with the flow fallback (morph/inbetween.h).
const char* const kInterpMethods[] = {"cross-dissolve", "linear",    "bands",
                                      "sharp",          "inbetween", "minterpolate"};

struct EvalArgs {
    std::vector<std::string> dirs;
    std::string output;
    bool overwrite = false, json = false;
    double density = morph::InbetweenOptions{}.morph.density, cell = morph::InbetweenOptions{}.cell;
};

void run_eval(const EvalArgs& a) {
    const std::vector<Sequence> seqs = sequences(a.dirs);
    check_folder(a.output, a.overwrite, a.dirs);
    prepare_folder(a.output, a.overwrite, a.dirs);
    const fs::path dir(a.output);
    nlohmann::json report = {{"sequences", nlohmann::json::array()}};
    std::map<std::string, std::pair<double, double>> sums;
    std::pair<double, double> seconds;  // inbetween, minterpolate
    ProgressBar bar;
    std::printf("%-16s", "sequence");
    for (const char* m : kInterpMethods) std::printf(" %15s", m);
    std::printf("   (PSNR dB / SSIM)\n");
    for (size_t s = 0; s < seqs.size(); ++s) {
        const Sequence& q = seqs[s];
        bar.update(double(s) / seqs.size(), q.name.c_str());
        const Image f0 = rgb(read_input(q.f0)), f1 = rgb(read_input(q.f1)),
                    truth = rgb(read_input(q.truth));
        if (f0.width != f1.width || f0.height != f1.height || truth.width != f0.width ||
            truth.height != f0.height) {
            throw Error(str(q.name, ": the three frames differ in size"));
        }
        if (truth.width < 16 || truth.height < 16) {
            throw Error(str(q.truth, ": ", truth.width, "x", truth.height,
                            " pixels; eval-interp needs at least 16x16 frames"));
        }
        std::vector<Image> results;
        results.push_back(dissolve(f0, f1));
        std::string note;
        const morph::PairMeshes pair = morph::automatic_pair_or_rest(f0, f1, a.cell, &note);
        if (!note.empty()) warn(str("note: ", q.name, ": ", note));
        for (morph::ScheduleKind k : {morph::ScheduleKind::linear, morph::ScheduleKind::bands,
                                      morph::ScheduleKind::sharp}) {
            const morph::MorphOptions o{.density = a.density, .schedule = {.kind = k}};
            results.push_back(morph::Morph(f0, f1, pair.a, pair.b, o).frame(0.5));
        }
        // The two timed methods, whole: ours from the frames to the frame, and FFmpeg's.
        morph::InbetweenOptions io;
        io.cell = a.cell;
        io.morph.density = a.density;
        auto clock = std::chrono::steady_clock::now();
        results.push_back(morph::inbetween(f0, f1, 0.5, io));
        const double ours = seconds_since(clock);
        clock = std::chrono::steady_clock::now();
        results.push_back(minterpolate_middle(f0, f1));
        const double theirs = seconds_since(clock);
        seconds.first += ours;
        seconds.second += theirs;
        nlohmann::json row = {{"sequence", q.name},
                              {"methods", nlohmann::json::object()},
                              {"seconds", {{"inbetween", ours}, {"minterpolate", theirs}}}};
        std::vector<Image> tiles = {truth};
        std::vector<std::string> captions = {q.name + ": truth"};
        std::printf("%-16s", q.name.c_str());
        for (size_t m = 0; m < results.size(); ++m) {
            const double p = psnr(truth, results[m]).all, ss = ssim(truth, results[m]).all;
            row["methods"][kInterpMethods[m]] = {{"psnr", p}, {"ssim", ss}};
            sums[kInterpMethods[m]].first += p;
            sums[kInterpMethods[m]].second += ss;
            std::printf("   %6.2f/%.4f", p, ss);
            tiles.push_back(results[m]);
            captions.push_back(str(kInterpMethods[m], " ", std::lround(p * 100) / 100.0, " dB"));
        }
        std::printf("\n");
        tiles.push_back(make_image(1, 1, 3));
        captions.push_back("error x4:");
        for (size_t m = 0; m < results.size(); ++m) {
            tiles.push_back(error_map(results[m], truth));
            captions.push_back(kInterpMethods[m]);
        }
        write_image(contact_sheet(tiles, captions, {.columns = 7}),
                    (dir / str("sheet_", q.name, ".png")).string());
        report["sequences"].push_back(row);
    }
    bar.update(1.0, "done");
    std::printf("%-16s", "average");
    for (const char* m : kInterpMethods) {
        const double p = sums[m].first / seqs.size(), ss = sums[m].second / seqs.size();
        report["average"][m] = {{"psnr", p}, {"ssim", ss}};
        std::printf("   %6.2f/%.4f", p, ss);
    }
    std::printf("\n");
    report["seconds"] = {{"inbetween", seconds.first}, {"minterpolate", seconds.second}};
    std::printf("time for all frames: inbetween %.2f s, minterpolate %.2f s (%.2fx its speed)\n",
                seconds.first, seconds.second, seconds.second / std::max(1e-9, seconds.first));
    write_file_atomic((dir / "eval.json").string(), report.dump(2) + "\n");
    if (a.json) std::printf("%s\n", report.dump(2).c_str());
    std::printf("outputs in %s (eval.json, sheet_*.png)\n", a.output.c_str());
}

}  // namespace

void add_eval_interp_command(CLI::App& app) {
    auto a = std::make_shared<EvalArgs>();
    CLI::App* cmd = app.add_subcommand(
        "eval-interp", "In-between frames against the truth: ours, cross-dissolve, minterpolate");
    cmd->add_option("dirs", a->dirs,
                    "Sequence folders (frame0/1/2.png or frame10/11/10i11.png), or folders of them")
        ->required();
    cmd->add_option("-o,--output", a->output, "Output folder")->required();
    cmd->add_flag("-y,--overwrite", a->overwrite, "Overwrite files in a non-empty folder");
    cmd->add_flag("--json", a->json, "Also print the report as JSON");
    cmd->add_option("--density", a->density, "Mesh samples per pixel")
        ->capture_default_str()
        ->check(density_range());
    cmd->add_option("--cell", a->cell, "Grid cell size of the fitted mesh, pixels")
        ->capture_default_str()
        ->check(CLI::Range(4.0, 1024.0));
    cmd->callback([a] { run_eval(*a); });
}

}  // namespace tesswave::cli
