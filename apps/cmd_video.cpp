// tesswave encode / decode: clips as .twv, coefficient deltas on a mesh that follows the content.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "core/eval/mesh_draw.h"
#include "core/io/frame_source.h"
#include "core/io/image_io.h"
#include "core/math/error.h"
#include "core/math/project.h"
#include "core/math/strings.h"
#include "frame_sink.h"
#include "video/dec_video.h"
#include "video/enc_video.h"

namespace tesswave::cli {
namespace {

namespace fs = std::filesystem;

struct EncodeArgs {
    std::string input, output, grid, motion = "tracked", size, pixel_format = "yuv420p", debug_dir;
    double kbps = 0, quality = 0, density = video::VideoEncodeOptions{}.density, intra_weight = 4,
           fps = 0, repeat_psnr = video::VideoEncodeOptions{}.repeat_psnr;
    int levels = 0, group = 33, motion_level = 0;
    int64_t max_frames = 0;
    std::string sampling = "fit";  // VideoEncodeOptions says why
    std::string chroma = "auto";
    std::string mesh_wavelet = "97";
    bool low_delay = false, mesh_only = false, overwrite = false, json = false;
};

// The label of a frame kind in --json and tables.
const char* kind_name(video::TwvFrameKind kind) {
    switch (kind) {
        case video::TwvFrameKind::intra:
            return "intra";
        case video::TwvFrameKind::delta:
            return "delta";
        default:
            return "band";
    }
}

// The mesh over the frame, and each track as a dot with a line to where it came from.
void write_debug_frame(const std::string& dir, const video::EncodedFrame& coded,
                       const Image& frame) {
    char name[40];
    std::snprintf(name, sizeof name, "frame_%05lld.png", static_cast<long long>(coded.number));
    const double scale = std::max(1.0, std::round(640.0 / std::max(frame.width, frame.height)));
    Image picture;
    if (coded.mesh) {
        Mesh m = *coded.mesh;  // drawn over the frame (a canvas reaches past it)
        m.vertices = coded.vertices;
        m.width = frame.width;
        m.height = frame.height;
        picture = draw_mesh(m, {.levels = 0, .scale = scale, .line_width = 1.0}, &frame);
    } else {
        picture = frame;
    }
    if (const auto* tracks = coded.live_tracks.empty() ? nullptr : &coded.live_tracks) {
        const double s = static_cast<double>(picture.width) / frame.width;
        auto dot = [&](Vec2 p, float r, float g, float b) {
            const int cx = static_cast<int>(p.x * s), cy = static_cast<int>(p.y * s);
            for (int y = cy - 1; y <= cy + 1; ++y) {
                for (int x = cx - 1; x <= cx + 1; ++x) {
                    if (x < 0 || y < 0 || x >= picture.width || y >= picture.height) continue;
                    picture.at(0, x, y) = r;
                    picture.at(1, x, y) = g;
                    picture.at(2, x, y) = b;
                }
            }
        };
        for (const video::Track& t : *tracks) {
            if (!t.born) {
                for (int i = 1; i < 8; ++i) {  // the last step, drawn 4x longer so it shows
                    const double f = 4.0 * i / 8;
                    dot(t.position + f * (t.previous - t.position), 1.0f, 0.85f, 0.0f);
                }
            }
            dot(t.position, t.born ? 0.2f : 0.1f, t.born ? 0.6f : 1.0f, t.born ? 1.0f : 0.1f);
        }
    }
    write_image(picture, (fs::path(dir) / name).string());
}

// The debug picture of a coded frame whose source `kept` holds (which then forgets it).
void draw_kept(std::map<int64_t, Image>& kept, const std::string& dir,
               const video::EncodedFrame& coded) {
    const auto it = kept.find(coded.number);
    if (it == kept.end()) return;
    write_debug_frame(dir, coded, it->second);
    kept.erase(it);
}

void run_encode(const EncodeArgs& a) {
    check_output(a.output, a.overwrite, {a.input});
    if (!a.debug_dir.empty()) check_folder(a.debug_dir, a.overwrite, {a.input});
    if (a.motion != "tracked" && a.motion != "none") {
        throw Error(str("--motion: expected tracked or none, got \"", a.motion, "\""));
    }
    const auto start = std::chrono::steady_clock::now();
    FrameSourceOptions so{.fps = a.fps, .pixel_format = a.pixel_format};
    if (!a.size.empty()) std::tie(so.width, so.height) = parse_cells(a.size, "--size");
    FrameSource source(a.input, so);
    if (source.trailing_bytes() > 0) {
        warn(str("warning: ", a.input, ": the last ", source.trailing_bytes(),
                 " bytes do not make a whole frame; they are not read"));
    }
    video::VideoEncodeOptions o{
        .transform = a.grid.empty()   ? TwiTransform::mesh
                     : a.grid == "97" ? TwiTransform::grid97
                                      : TwiTransform::grid53,
        .motion = a.motion == "none" ? video::TwvMotion::none : video::TwvMotion::tracked,
        .motion_level = a.motion_level,
        .density = a.density,
        .levels = a.levels,
        .mesh_wavelet = mesh_wavelet_from_name(a.mesh_wavelet),
        .group = a.group,
        .low_delay = a.low_delay,
        .repeat_psnr = a.repeat_psnr,
        .chroma_420 = a.chroma == "420" || (a.chroma == "auto" && source.chroma_subsampled()),
        .kbps = a.kbps,
        .intra_weight = a.intra_weight,
        .grid_groups = !a.mesh_only};
    if (a.quality > 0) o.quality = a.quality;
    o.sampling = sampling_from_name(a.sampling);
    if (o.kbps > 0) o.quality = 0;  // the rate decides
    const int64_t total = a.max_frames > 0 ? a.max_frames : source.frame_count_estimate();
    ProgressBar bar;
    int64_t n = 0;
    video::GroupCount groups;
    int64_t repeated = 0;            // frames shown again, not coded
    int64_t* given_count = nullptr;  // set below: frames given to the encoder
    if (total > 0) {
        o.progress = [&bar, &given_count, total](double done, const char* stage) {
            const int64_t g = given_count ? *given_count : 0;
            bar.update((static_cast<double>(g) + done) / static_cast<double>(total),
                       str("frame ", g + 1, ": ", stage).c_str());
        };
    }
    std::unique_ptr<video::VideoEncoder> encoder;
    try {
        encoder = std::make_unique<video::VideoEncoder>(a.output, source.width(), source.height(),
                                                        source.fps() > 0 ? source.fps() : 25, o);
    } catch (const Error& e) {
        throw Error(str(a.input, ": ", e.what()));
    }
    if (!a.debug_dir.empty()) prepare_folder(a.debug_dir, a.overwrite, {a.input});
    nlohmann::json frames = nlohmann::json::array();
    Image frame;
    double psnr_sum = 0;
    int64_t given = 0;
    given_count = &given;
    std::map<int64_t, Image> drawn;  // --debug-dir: frames given and not yet coded
    // A coded frame: its line in --json, its PSNR, the warnings it brings.
    const auto take = [&](const video::EncodedFrame& f) {
        draw_kept(drawn, a.debug_dir, f);
        psnr_sum += std::min(f.psnr, 100.0);  // identical frames count as 100 dB, as x264 does
        if (o.quality > 0 && f.first_in_group && f.quality_target < o.quality && !a.json) {
            char line[160];
            std::snprintf(line, sizeof line,
                          "frame %lld: %.2f dB is out of reach on this mesh (its resampling caps "
                          "it); coding for %.2f dB",
                          static_cast<long long>(f.number), o.quality, f.quality_target);
            warn(str("warning: ", a.input, ": ", line));
        }
        groups.add(f);
        repeated += f.repeat;
        frames.push_back({{"frame", f.number},
                          {"kind", kind_name(f.kind)},
                          {"repeat", f.repeat},
                          {"bytes", f.bytes},
                          {"motion_bytes", f.motion_bytes},
                          {"psnr", f.psnr},
                          {"tracks", f.tracks},
                          {"fit_rms", f.fit_rms},
                          {"new_group", f.new_group},
                          {"group_domain", f.grid_group     ? "grid97"
                                           : f.static_group ? "static"
                                           : f.canvas_group ? "canvas"
                                                            : "own"},
                          {"quality_target", f.quality_target}});
        ++n;
    };
    const auto coded = [&](std::vector<video::EncodedFrame> done) {
        for (const video::EncodedFrame& f : done) take(f);
    };
    while ((a.max_frames <= 0 || given < a.max_frames) && source.read(frame)) {
        if (!a.debug_dir.empty()) drawn.emplace(given, frame);
        try {
            coded(encoder->encode(frame));
        } catch (const Error& e) {
            throw Error(str(a.input, ": frame ", given, ": ", e.what()));
        }
        ++given;
    }
    coded(encoder->flush());
    // A container that declares more frames than its stream holds was cut (libav reads a cut
    // .mkv or .mp4 to its end without an error).
    if (a.max_frames <= 0 && total > 0 && given + 1 < total * 0.95) {
        warn(str("warning: ", a.input, ": the stream ends after ", given, " frames of the ", total,
                 " its container declares (a cut file?)"));
    }
    const int64_t bytes = encoder->finish();
    if (encoder->padding() > 0) {
        warn(str("note: ", a.output, ": the clip codes to ", bytes - encoder->padding(), " bytes; ",
                 encoder->padding(),
                 " bytes of padding let a decoder grant its decoding work (a tiny file may "
                 "only claim a little)"));
    }
    bar.clear();
    const double seconds = seconds_since(start);
    const double fps = encoder->header().fps();
    const double kbps = bytes * 8.0 / 1000 / (n / fps);
    const double bpp = bytes * 8.0 / (static_cast<double>(n) * source.width() * source.height());
    nlohmann::json j = {{"input", a.input},
                        {"output", a.output},
                        {"width", source.width()},
                        {"height", source.height()},
                        {"frames", n},
                        {"groups", groups.groups},
                        {"static_groups", groups.static_groups},
                        {"grid_groups", groups.grid_groups},
                        {"canvas_groups", groups.canvas_groups},
                        {"repeated_frames", repeated},
                        {"bytes", bytes},
                        {"padding_bytes", encoder->padding()},
                        {"kbps", kbps},
                        {"bpp", bpp},
                        {"psnr", psnr_sum / n},
                        {"seconds", seconds},
                        {"fps", n / seconds}};
    if (a.json) {
        j["per_frame"] = frames;
        std::printf("%s\n", j.dump(2).c_str());
        return;
    }
    std::string kept;  // which groups left the clip's own domain
    if (groups.static_groups > 0) kept += str(", ", groups.static_groups, " on the static mesh");
    if (groups.grid_groups > 0) kept += str(", ", groups.grid_groups, " on the fixed grid");
    if (groups.canvas_groups > 0) kept += str(", ", groups.canvas_groups, " on a canvas");
    if (repeated > 0) kept += str(", ", repeated, " frames repeated");
    std::printf(
        "%s: %lld frame%s %dx%d in %lld group%s%s, %lld bytes, %.1f kbit/s at %.3g fps "
        "(%.4f bpp), mean PSNR %.2f dB; %.1f frames/s\n",
        a.output.c_str(), static_cast<long long>(n), n == 1 ? "" : "s", source.width(),
        source.height(), static_cast<long long>(groups.groups), groups.groups == 1 ? "" : "s",
        kept.c_str(), static_cast<long long>(bytes), kbps, fps, bpp, psnr_sum / n, n / seconds);
}

struct DecodeArgs {
    std::string input, output, frames;
    int64_t max_pixels = 0;
    H264Settings h264;
    bool overwrite = false, json = false;
};

std::pair<int64_t, int64_t> parse_range(const std::string& text) {
    if (text.empty()) return {0, INT64_MAX};
    const size_t colon = text.find(':');
    auto number = [&](const std::string& s, int64_t fallback) -> int64_t {
        if (s.empty()) return fallback;
        size_t used = 0;
        long long v = -1;
        try {
            v = std::stoll(s, &used);
        } catch (const std::exception&) {
        }
        if (used != s.size() || v < 0) {
            throw CLI::ValidationError("--range",
                                       str("expected A:B with frame numbers, got \"", text, "\""));
        }
        return v;
    };
    if (colon == std::string::npos) {
        const int64_t f = number(text, -1);
        return {f, f};
    }
    const int64_t a = number(text.substr(0, colon), 0);
    const int64_t b = number(text.substr(colon + 1), INT64_MAX);
    if (b < a) throw CLI::ValidationError("--range", str("\"", text, "\" is empty"));
    return {a, b};
}

void run_decode(const DecodeArgs& a) {
    FrameSink::check_path(a.output);
    check_output(a.output, a.overwrite, {a.input});
    const auto [first, last] = parse_range(a.frames);
    const auto start = std::chrono::steady_clock::now();
    video::VideoDecoder decoder(a.input, limits_for<video::TwvLimits>(a.max_pixels));
    const video::TwvHeader& h = decoder.header();
    if (!decoder.seek(first)) {
        throw Error(decoder.damage().empty() ? str(a.input, ": the clip ends before frame ", first)
                                             : decoder.damage());
    }
    FrameSink sink(a.output, h.width, h.height, h.fps(), a.h264);
    ProgressBar bar;
    const int64_t count = decoder.frame_count().value_or(-1);
    const int64_t end = count > 0 ? std::min(last, count - 1) : last;
    Image frame;
    for (int64_t f = first; f <= last && decoder.read(frame); ++f) {
        sink.write(frame);
        if (end < INT64_MAX)
            bar.update(double(f - first + 1) / double(end - first + 1), "decoding");
    }
    if (sink.frames() == 0)
        throw Error(decoder.damage().empty() ? str(a.input, ": no frames") : decoder.damage());
    sink.finish();
    bar.clear();
    const double seconds = seconds_since(start);
    if (!decoder.damage().empty()) {
        warn(
            str("warning: ", decoder.damage(), "; wrote the ", sink.frames(), " frames before it"));
    }
    if (a.json) {
        std::printf("%s\n", nlohmann::json{{"input", a.input},
                                           {"output", a.output},
                                           {"first", first},
                                           {"frames", sink.frames()},
                                           {"damage", decoder.damage()},
                                           {"seconds", seconds},
                                           {"fps", sink.frames() / seconds}}
                                .dump(2)
                                .c_str());
        return;
    }
    std::printf("%s: %lld frames %dx%d from frame %lld; %.1f frames/s\n", a.output.c_str(),
                static_cast<long long>(sink.frames()), h.width, h.height,
                static_cast<long long>(first), sink.frames() / seconds);
}

}  // namespace

std::vector<std::string> video_demo(const std::string& clip, const std::string& dir) {
    const double kbps = 300;
    std::printf("\nvideo codec (.twv) on %s at %.0f kbit/s:\n", clip.c_str(), kbps);
    struct Method {
        const char* name;
        const char* file;
        video::VideoEncodeOptions options;
    };
    // The mesh alone (every group on it), to show what it buys over the fixed grid.
    const Method methods[] = {
        {"moving mesh", "clip.twv", {.kbps = kbps, .grid_groups = false}},
        {"static mesh",
         "clip_static.twv",
         {.motion = video::TwvMotion::none, .kbps = kbps, .grid_groups = false}},
        {"fixed grid 5/3", "clip_grid53.twv", {.transform = TwiTransform::grid53, .kbps = kbps}},
    };
    const std::string mesh_dir = (fs::path(dir) / "clip_mesh").string();
    prepare_folder(mesh_dir, true);
    std::vector<std::string> written{mesh_dir + "/ (frames 0, 10, 20 with the mesh and tracks)"};
    double psnr[3] = {};
    for (int k = 0; k < 3; ++k) {
        const Method& m = methods[k];
        FrameSource source(clip);
        const std::string path = (fs::path(dir) / m.file).string();
        video::VideoEncoder encoder(path, source.width(), source.height(), source.fps(), m.options);
        Image frame;
        int64_t n = 0, groups = 0;
        const auto start = std::chrono::steady_clock::now();
        std::map<int64_t, Image> drawn;  // frames to draw the mesh over, until they are coded
        const auto take = [&](const std::vector<video::EncodedFrame>& done) {
            for (const video::EncodedFrame& f : done) {
                psnr[k] += std::min(f.psnr, 100.0);
                groups += f.first_in_group;
                ++n;
                draw_kept(drawn, mesh_dir, f);
            }
        };
        for (int64_t given = 0; source.read(frame); ++given) {
            if (k == 0 && given % 10 == 0 && given <= 20) drawn.emplace(given, frame);
            take(encoder.encode(frame));
        }
        take(encoder.flush());
        const int64_t bytes = encoder.finish();
        const double seconds = seconds_since(start);
        written.push_back(path);
        psnr[k] /= n;
        std::printf(
            "  %-15s %6lld bytes  %6.1f kbit/s  %.3f bpp  PSNR %6.2f dB  %2lld groups  "
            "%5.1f frames/s\n",
            m.name, static_cast<long long>(bytes), bytes * 8.0 / 1000 / (n / source.fps()),
            bytes * 8.0 / (double(n) * source.width() * source.height()), psnr[k],
            static_cast<long long>(groups), n / seconds);
    }
    std::printf("  moving mesh: %+.2f dB over the static mesh, %+.2f dB over the fixed-grid 5/3\n",
                psnr[0] - psnr[1], psnr[0] - psnr[2]);
    video::VideoDecoder decoder((fs::path(dir) / "clip.twv").string());
    const std::string decoded = (fs::path(dir) / "clip_decoded.mp4").string();
    FrameSink sink(decoded, decoder.header().width, decoder.header().height,
                   decoder.header().fps());
    Image frame;
    while (decoder.read(frame)) sink.write(frame);
    sink.finish();
    written.push_back(decoded);
    return written;
}

void add_video_commands(CLI::App& app) {
    auto e = std::make_shared<EncodeArgs>();
    auto* enc = app.add_subcommand("encode",
                                   "Compress a clip to .twv (wavelets on a mesh that follows "
                                   "the content, lifted along time)");
    enc->add_option("input", e->input,
                    "Clip: any file FFmpeg reads, a folder of frames, or raw .yuv (with --size)")
        ->required();
    enc->add_option("-o,--output", e->output, "Output .twv file")
        ->required()
        ->check(output_extension({".twv"}, "encode", "a .twv file"));
    auto* kbps = enc->add_option("--kbps", e->kbps,
                                 "Rate in kbit/s (each group gets its frames' share, its bands "
                                 "cut at one rate-distortion slope)")
                     ->check(positive("a rate"));
    enc->add_option("--psnr", e->quality,
                    str("Target PSNR in dB (default ", video::VideoEncodeOptions{}.quality,
                        ": about x264's default rate)"))
        ->check(CLI::Range(10.0, 80.0))
        ->excludes(kbps);
    enc->add_option("--grid", e->grid, "Fixed-grid wavelet on the pixels instead: 53 or 97")
        ->check(CLI::IsMember({"53", "97"}));
    enc->add_option("--motion", e->motion, "Mesh motion: tracked (default) or none (static mesh)")
        ->check(CLI::IsMember({"tracked", "none"}));
    enc->add_option("--motion-level", e->motion_level,
                    "The moving mesh is T_k of the base grid (finer motion, k levels fewer)")
        ->check(CLI::Range(0, 6));
    enc->add_option("--density", e->density, "Mesh samples per pixel")
        ->capture_default_str()
        ->check(density_range());
    enc->add_option("-J,--levels", e->levels, "Mesh level J, or fixed-grid levels")
        ->check(CLI::Range(1, 12));
    add_mesh_wavelet_option(*enc, e->mesh_wavelet);
    enc->add_option("-g,--group", e->group,
                    "Intra period: at most this many frames a group (default 33)")
        ->check(CLI::Range(1, 100000));
    enc->add_flag("--mesh-only", e->mesh_only,
                  "Code every group on the mesh (by default a group is also coded on the "
                  "fixed-grid 9/7 and kept there when that is better)");
    auto* low_delay =
        enc->add_flag("--low-delay", e->low_delay,
                      "Code each frame as it comes (closed-loop deltas) instead of lifting each "
                      "group along time, which takes a group of latency and gives more quality per "
                      "bit");
    enc->add_option("--repeat-psnr", e->repeat_psnr,
                    "A frame this close (PSNR in dB, over the whole frame) to the last frame coded "
                    "is shown again instead of coded (lifted groups; 0: never; with --psnr Q at "
                    "least Q + 6; default " +
                        str(video::VideoEncodeOptions{}.repeat_psnr) + ")")
        ->check(CLI::Range(0.0, 200.0));
    enc->add_option("--intra-weight", e->intra_weight,
                    "With --low-delay and --kbps: an intra frame's budget in delta frames "
                    "(default 4)")
        ->check(CLI::Range(1.0, 100.0))
        ->needs(low_delay);
    enc->add_option("--chroma", e->chroma,
                    "Chroma resolution: 420 (one mesh level coarser), 444 (full), or auto (420 "
                    "when the source is subsampled; default)")
        ->check(CLI::IsMember({"auto", "420", "444"}));
    enc->add_option("--frames", e->max_frames, "Code at most this many frames")
        ->check(CLI::Range(int64_t{1}, int64_t{100'000'000}));
    enc->add_option("--fps", e->fps, "Frame rate (default: the clip's, or 25)")
        ->check(CLI::Range(0.001, 1000.0));
    enc->add_option("--size", e->size, "Raw .yuv input: frame size WxH");
    enc->add_option("--pix-fmt", e->pixel_format,
                    "Raw .yuv input: yuv420p, yuv422p, yuv444p, gray");
    enc->add_option("--debug-dir", e->debug_dir,
                    "Write each frame with its mesh and tracks as PNG into this folder");
    add_sampling_option(enc, e->sampling);
    enc->add_flag("-y,--overwrite", e->overwrite, "Overwrite outputs");
    enc->add_flag("--json", e->json, "Print the result (and every frame) as JSON");
    enc->callback([e, enc] {
        refuse_unused(*enc, {"--size", "--pix-fmt"}, lowercase_extension(e->input) == ".yuv",
                      "raw .yuv input only");
        run_encode(*e);
    });

    auto d = std::make_shared<DecodeArgs>();
    auto* dec = app.add_subcommand("decode", "Decompress a .twv clip");
    dec->add_option("input", d->input, "Input .twv file")->required();
    dec->add_option("-o,--output", d->output,
                    "Output: .mp4 or .mov (H.264), .mkv (lossless FFV1), .y4m, .gif, or a folder "
                    "for PNG frames")
        ->required();
    dec->add_option("--range", d->frames, "Frames A:B (inclusive; A: or :B open), or one frame");
    add_max_pixels_option(dec, d->max_pixels);
    add_h264_options(dec, d->h264);
    dec->add_flag("-y,--overwrite", d->overwrite, "Overwrite the output");
    dec->add_flag("--json", d->json, "Print the result as JSON");
    dec->callback([d, dec] {
        refuse_unused(*dec, {"--crf", "--preset"}, is_h264_output(d->output),
                      ".mp4/.mov output only");
        run_decode(*d);
    });
}

}  // namespace tesswave::cli
