// tesswave compare-video: the video codec's four domains (moving mesh, static mesh, fixed-grid
// 5/3 and 9/7) beside FFmpeg's Snow, VC-2 and x264 at equal rates, with CSV, JSON, a summary table,
// Bjontegaard deltas, rate-distortion plots and one decoded frame per method side by side.
#include <stdlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <set>
#include <sstream>

#include "cli.h"
#include "core/eval/compare_video.h"
#include "core/eval/contact_sheet.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/math/error.h"
#include "core/math/project.h"
#include "core/math/strings.h"

namespace fs = std::filesystem;

namespace tesswave::cli {
namespace {

using namespace eval;  // the compare-video harness

struct CompareVideoArgs {
    std::vector<std::string> clips;
    // 0.02 to 0.8 bpp: from below x264's default rate on easy clips to near-transparent.
    std::vector<std::string> rates = {"0.02", "0.05", "0.1", "0.2", "0.4", "0.8"};
    std::vector<std::string> methods = {"moving", "static", "grid53", "grid97", "snow", "x264"};
    std::string output, size, pixel_format = "yuv420p";
    int64_t frames = 0, shown_frame = -1;
    int group = 33;
    double fps = 0;
    std::string sampling = "fit";  // VideoEncodeOptions says why
    std::string mesh_wavelet = "97";
    bool mesh_only = false, overwrite = false, json = false;
};

// An item of --rates: bits per pixel, or kbit/s with a k suffix.
struct Rate {
    std::string text;
    double value = 0;
    bool kbps = false;
    double bpp(const ClipInfo& c) const {
        return kbps ? value * 1000 / (static_cast<double>(c.width) * c.height * c.fps) : value;
    }
};

std::vector<Rate> parse_rates(const std::vector<std::string>& items) {
    std::vector<Rate> rates;
    for (const std::string& item : items) {
        Rate r{item};
        r.kbps = !item.empty() && (item.back() == 'k' || item.back() == 'K');
        const std::string number = r.kbps ? item.substr(0, item.size() - 1) : item;
        char* end = nullptr;
        r.value = std::strtod(number.c_str(), &end);
        if (number.empty() || *end != '\0' || !(r.value > 0) || r.value > (r.kbps ? 1e7 : 64)) {
            throw CLI::ValidationError(
                "--rates",
                str("'", item, "' is neither bits per pixel in (0, 64] nor kbit/s like 300k"));
        }
        rates.push_back(r);
    }
    if (rates.empty()) throw CLI::ValidationError("--rates", "no rates given");
    return rates;
}

std::vector<VideoMethod> parse_methods(const std::vector<std::string>& ids) {
    std::set<VideoMethod> chosen;
    for (const std::string& id : ids) chosen.insert(method_from_id(id));
    if (chosen.empty()) throw CLI::ValidationError("--methods", "no methods given");
    std::vector<VideoMethod> methods;
    for (VideoMethod m : kVideoMethods) {
        if (chosen.count(m)) methods.push_back(m);
    }
    return methods;
}

// Reads the clip through: it opens, every frame has the first one's size, and it has frames;
// then reads it again up to the frame shown side by side, which it returns.
ClipInfo probe_clip(const std::string& path, const CompareVideoArgs& a,
                    const FrameSourceOptions& so, Image& shown) {
    FrameSource source(path, so);
    if (source.trailing_bytes() > 0) {
        warn(str("warning: ", path, ": the last ", source.trailing_bytes(),
                 " bytes do not make a whole frame; they are not read"));
    }
    // A folder's name is its stem ("aerial-6.2/" is aerial-6.2); a file's loses its extension.
    fs::path p = fs::path(path).lexically_normal();
    if (p.filename().empty()) p = p.parent_path();
    const bool folder = fs::is_directory(p);
    ClipInfo c{path,           p.filename().string(), (folder ? p.filename() : p.stem()).string(),
               source.width(), source.height(),       source.fps() > 0 ? source.fps() : 25};
    if (c.width < 8 || c.height < 8) {
        throw Error(str(path, ": ", c.width, "x", c.height, " frames are under 8x8 (SSIM)"));
    }
    c.chroma_420 = source.chroma_subsampled();
    c.source_codec = source.source_codec();
    c.source_bpp = source.source_bits_per_pixel();
    if (const std::string note = source_note(c); !note.empty()) warn("note: " + note);
    const int64_t limit = a.frames > 0 ? a.frames : INT64_MAX;
    while (c.frames < limit && source.read(shown)) ++c.frames;
    if (a.shown_frame >= c.frames) {
        throw Error(str("--frame ", a.shown_frame, ": ", path, " has ", c.frames, " frames",
                        a.frames > 0 ? " (with --frames)" : ""));
    }
    c.shown_frame = a.shown_frame >= 0 ? a.shown_frame : c.frames / 2;
    FrameSource again(path, so);
    for (int64_t n = 0; n <= c.shown_frame; ++n) {
        if (!again.read(shown)) throw Error(str(path, ": the clip got shorter"));
    }
    return c;
}

// Clip names and file stems made unique (two clips may share a file name).
void make_unique(std::vector<ClipInfo>& clips) {
    std::set<std::string> names, stems;
    for (ClipInfo& c : clips) {
        if (!names.insert(c.name).second) c.name = c.path;
        const std::string stem = c.stem;
        for (int k = 2; !stems.insert(c.stem).second; ++k) c.stem = str(stem, "_", k);
    }
}

// A folder for our .twv streams while they are decoded, removed with everything in it.
class ScratchFolder {
  public:
    ScratchFolder() {
        std::string pattern =
            (fs::temp_directory_path() / "tesswave-compare-video-XXXXXX").string();
        if (!::mkdtemp(pattern.data())) throw Error(str(pattern, ": cannot create a folder"));
        path_ = pattern;
    }
    ~ScratchFolder() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    ScratchFolder(const ScratchFolder&) = delete;
    ScratchFolder& operator=(const ScratchFolder&) = delete;
    const std::string& path() const { return path_; }

  private:
    std::string path_;
};

// A tile of the side-by-side picture: a centre crop of big frames, small ones enlarged by pixel
// replication (QCIF 3x, CIF 2x) so that artefacts show and the captions fit.
Image tile(const Image& frame) {
    const Image crop = centre_crop(frame, 480, 360);
    const int k = std::clamp((420 + crop.width - 1) / crop.width, 1, 4);
    if (k == 1) return crop;
    Image out = make_image(crop.width * k, crop.height * k, crop.channels(), crop.format);
    for (int c = 0; c < crop.channels(); ++c) {
        for (int y = 0; y < out.height; ++y) {
            for (int x = 0; x < out.width; ++x) out.at(c, x, y) = crop.at(c, x / k, y / k);
        }
    }
    return out;
}

// The method, its rate, and the PSNR-Y of the frame shown.
std::string caption(const VideoRow& r, const Image& original, const Image& shown) {
    return str(r.method, ": ", std::lround(r.bpp * 1000) / 1000.0, " bpp, Y ",
               std::lround(luma_psnr(original, shown) * 10) / 10.0, " dB");
}

std::string rate_name(const Rate& r) { return r.kbps ? str(r.value, "kbps") : str(r.value, "bpp"); }

nlohmann::json settings_json(const CompareVideoArgs& a, const std::vector<Rate>& rates,
                             const std::vector<VideoMethod>& methods) {
    nlohmann::json j = {
        {"group", a.group},
        {"frames", a.frames > 0 ? nlohmann::json(a.frames) : nlohmann::json()},
        {"rates", nlohmann::json::array()},
        {"methods", nlohmann::json::array()},
        {"bd_references",
         [] {
             nlohmann::json refs = nlohmann::json::array();
             for (VideoMethod m : kBdReferences) refs.push_back(method_label(m));
             return refs;
         }()},
        {"ours", "default encode options, --kbps from the rate, --group"},
        {"snow", "qscale searched for the rate (5 %, 8 encodes at most), gop = group"},
        {"vc2", "kbps from the rate (its rate mode)"},
        {"x264",
         "preset medium, CRF searched for the rate (5 %, 8 encodes at "
         "most), keyint = group"},
        {"peer_threads", 1}};
    for (const Rate& r : rates) j["rates"].push_back(r.text);
    for (VideoMethod m : methods) j["methods"].push_back(method_id(m));
    return j;
}

// Everything that is printed and written once all runs are done.
void write_report(const CompareVideoArgs& a, const std::vector<ClipInfo>& clips,
                  const std::vector<VideoRow>& rows, const std::vector<VideoMethod>& methods,
                  const nlohmann::json& settings, double seconds) {
    const fs::path dir(a.output);
    const std::vector<BdRow> bd = bd_rates(clips, rows, methods);
    const std::string table = summary_table(clips, rows, bd);
    nlohmann::json j = results_json(clips, rows, bd, settings);
    j["seconds"] = seconds;
    write_file_atomic((dir / "results.csv").string(), results_csv(rows));
    write_file_atomic((dir / "bd_rate.csv").string(), bd_csv(bd));
    write_file_atomic((dir / "results.json").string(), j.dump(2));
    write_file_atomic((dir / "summary.txt").string(), table);
    if (a.json) {
        std::printf("%s\n", j.dump(2).c_str());
    } else {
        std::printf("%soutputs in %s (%.1f s)\n", table.c_str(), a.output.c_str(), seconds);
    }
}

// The state of one command run: what every (clip, rate) step needs and what it adds to.
struct Session {
    explicit Session(const CompareVideoArgs& a)
        : args(a), methods(parse_methods(a.methods)), dir(a.output) {
        source.fps = a.fps;
        source.pixel_format = a.pixel_format;
        if (!a.size.empty()) std::tie(source.width, source.height) = parse_cells(a.size, "--size");
    }
    const CompareVideoArgs& args;
    std::vector<VideoMethod> methods{};
    FrameSourceOptions source{};
    fs::path dir{};
    std::string scratch{};
    ProgressBar bar{};
    double total = 0, done = 0;  // pixels to code, summed over the runs, and coded so far
    std::vector<VideoRow> rows{};
};

// Every method at one rate on one clip: rows added, the side-by-side picture written.
void compare_at_rate(Session& s, const ClipInfo& clip, const Image& original, const Rate& rate) {
    std::vector<Image> tiles = {tile(original)};
    std::vector<std::string> captions = {str("original, frame ", clip.shown_frame, " (target ",
                                             rate.text, rate.kbps ? "bit/s)" : " bpp)")};
    for (VideoMethod m : s.methods) {
        const RunContext context{
            &clip,
            s.source,
            s.args.group,
            s.scratch,
            [&](double f, const char* what) {
                const std::string stage =
                    str(clip.stem, " ", method_id(m), " ", rate.text, " ", what);
                s.bar.update((s.done + f * clip.pixels()) / s.total, stage.substr(0, 30).c_str());
            },
            sampling_from_name(s.args.sampling),
            s.args.mesh_only,
            mesh_wavelet_from_name(s.args.mesh_wavelet)};
        Image shown;
        VideoRow row = run_video_method(context, m, rate.bpp(clip), &shown);
        row.rate = rate.text;
        if (row.error.empty()) {
            tiles.push_back(tile(shown));
            captions.push_back(caption(row, original, shown));
        }
        s.rows.push_back(std::move(row));
        s.done += clip.pixels();
    }
    write_image(contact_sheet(tiles, captions, {.columns = 4}),
                (s.dir / str("frame_", clip.stem, "_", rate_name(rate), ".png")).string());
}

// Checks every input, then codes every clip at every rate with every method; returns the rows.
std::vector<VideoRow> run_all(Session& s, const std::vector<Rate>& rates,
                              std::vector<ClipInfo>& clips) {
    const CompareVideoArgs& a = s.args;
    check_folder(a.output, a.overwrite, a.clips);
    std::vector<Image> originals;
    for (const std::string& path : a.clips) {
        originals.emplace_back();
        clips.push_back(probe_clip(path, a, s.source, originals.back()));
        s.total += clips.back().pixels() * static_cast<double>(rates.size() * s.methods.size());
    }
    make_unique(clips);
    prepare_folder(a.output, a.overwrite, a.clips);
    const ScratchFolder scratch;
    s.scratch = scratch.path();
    for (size_t i = 0; i < clips.size(); ++i) {
        for (const Rate& rate : rates) compare_at_rate(s, clips[i], originals[i], rate);
        write_image(rd_plot(clips[i], s.rows, s.methods),
                    (s.dir / str("rd_", clips[i].stem, ".png")).string());
        write_file_atomic((s.dir / "results.csv").string(), results_csv(s.rows));  // so far
    }
    return std::move(s.rows);
}

void run_compare_video(const CompareVideoArgs& a) {
    const auto start = std::chrono::steady_clock::now();
    const std::vector<Rate> rates = parse_rates(a.rates);
    std::vector<ClipInfo> clips;
    std::vector<VideoRow> rows;
    std::vector<VideoMethod> methods;
    {
        Session s(a);
        methods = s.methods;
        rows = run_all(s, rates, clips);
    }  // the progress bar is cleared before the table is printed
    write_report(a, clips, rows, methods, settings_json(a, rates, methods), seconds_since(start));
}

}  // namespace

void add_compare_video_command(CLI::App& app) {
    auto a = std::make_shared<CompareVideoArgs>();
    CLI::App* cmd = app.add_subcommand(
        "compare-video",
        "Moving mesh, static mesh, fixed-grid 5/3 and 9/7 vs Snow and x264 (and VC-2) at equal "
        "rates");
    cmd->footer(
        "Every clip is coded at every rate by every method, decoded and measured against the "
        "clip: bits per pixel of the whole stream (our .twv file; the peers' packets and "
        "headers), PSNR-Y (BT.601 luma of the RGB frames), PSNR and SSIM over R, G, B (means over "
        "the frames), and frames a second. Ours take the rate as kbit/s = bpp * W * H * fps / "
        "1000; Snow's qscale and x264's CRF are searched until the stream is within 5 % of the "
        "rate (8 encodes at most; the achieved rate is reported); VC-2 uses its rate mode, which "
        "has a floor of about 1.8 bpp (runs below it are reported as failed). The peers run "
        "single-threaded on yuv420p (x264: preset medium), so their numbers include the 4:2:0 "
        "round trip; ours code chroma one mesh level coarser when the source is subsampled "
        "(4:2:0). Every method gets the same intra period (--group). VC-2 is not run unless "
        "--methods names it. "
        "BD-rates (Bjontegaard, on the achieved bpp) are against grid 5/3, Snow and x264 (those "
        "run) and need 4 rates or more. A clip that a block-transform codec coded (H.264, VP9, "
        "...) gets a note with the source's codec and rate: a peer of its kind can code the "
        "source's own blocks again (x264 on H.264), which favours it; a crop off the block grid "
        "compares without that.\n"
        "Writes into the folder: results.csv, results.json, bd_rate.csv, summary.txt (the "
        "table printed), rd_<clip>.png (PSNR-Y and PSNR against bpp, one line per method) and "
        "frame_<clip>_<rate>.png (one decoded frame per method side by side with its bpp and "
        "its own PSNR-Y: centre crops of big frames, small ones enlarged).");
    cmd->add_option("clips", a->clips,
                    "Clips: files FFmpeg reads, folders of frames, or raw .yuv (with --size)")
        ->required();
    cmd->add_option("--rates", a->rates,
                    "Rates, comma-separated: bits per pixel (0.1) or kbit/s with a k suffix (300k)")
        ->delimiter(',')
        ->capture_default_str();
    cmd->add_option("--methods", a->methods,
                    "Methods, comma-separated: moving, static, grid53, grid97, snow, vc2, x264")
        ->delimiter(',')
        ->capture_default_str()
        ->check(CLI::IsMember({"moving", "static", "grid53", "grid97", "snow", "vc2", "x264"}));
    cmd->add_option("--frames", a->frames, "Use the first N frames of each clip (default: all)")
        ->check(CLI::Range(int64_t{1}, int64_t{100'000'000}));
    cmd->add_option("--frame", a->shown_frame,
                    "The frame shown side by side (default: the middle one)")
        ->check(CLI::Range(int64_t{0}, int64_t{100'000'000}));
    cmd->add_option("-g,--group", a->group, "Intra period of every method, in frames")
        ->capture_default_str()
        ->check(CLI::Range(1, 100000));
    cmd->add_option("--fps", a->fps, "Frame rate (default: the clip's, or 25)")
        ->check(CLI::Range(0.001, 1000.0));
    cmd->add_option("--size", a->size, "Raw .yuv input: frame size WxH");
    cmd->add_option("--pix-fmt", a->pixel_format,
                    "Raw .yuv input: yuv420p, yuv422p, yuv444p, gray");
    cmd->add_option("-o,--output", a->output, "Output folder")->required();
    add_sampling_option(cmd, a->sampling);
    add_mesh_wavelet_option(*cmd, a->mesh_wavelet);
    cmd->add_flag("--mesh-only", a->mesh_only,
                  "The moving mesh codes every group on the mesh (by default a group is also "
                  "coded on the fixed-grid 9/7 and kept there when that is better)");
    cmd->add_flag("-y,--overwrite", a->overwrite, "Overwrite files in a non-empty folder");
    cmd->add_flag("--json", a->json, "Print the whole result as JSON");
    cmd->callback([a, cmd] {
        const bool raw = std::any_of(a->clips.begin(), a->clips.end(), [](const std::string& c) {
            return lowercase_extension(c) == ".yuv";
        });
        refuse_unused(*cmd, {"--size", "--pix-fmt"}, raw, "raw .yuv clips only");
        run_compare_video(*a);
    });
}

}  // namespace tesswave::cli
