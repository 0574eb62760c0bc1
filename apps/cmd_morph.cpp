// tesswave morph / inbetween: morphs between two images on meshes of one topology, the frequency
// bands blended on their own schedules.
#include "cmd_morph.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/io/mesh_io.h"
#include "core/math/error.h"
#include "core/math/parallel.h"
#include "core/math/project.h"
#include "core/math/strings.h"
#include "frame_sink.h"
#include "morph/auto_match.h"
#include "morph/faces.h"
#include "morph/inbetween.h"
#include "morph/morph.h"
#include "morph/pair.h"

namespace fs = std::filesystem;

namespace tesswave::cli {
namespace {

constexpr int kGifSide = 320;  // default longest side of a GIF morph (about 1.5 MB for 30 frames)
// --loop keeps the frames it shows again on the way back while they take at most this much.
constexpr double kLoopBytes = 512.0 * (1 << 20);

// --at writes one image; otherwise the frames go to a FrameSink.
void check_morph_output(const MorphArgs& a) {
    if (!a.mesh.empty() && a.mesh != "triangulation" && !is_mesh_generator(a.mesh)) {
        throw CLI::ValidationError(
            "--mesh",
            str("'", a.mesh,
                "': a morph fits its meshes, give triangulation, grid[:CxR] or voronoi[:N]"));
    }
    if (a.at < 0) {
        FrameSink::check_path(a.output);
        if (lowercase_extension(a.output) == ".gif" && a.fps > 100) {
            throw CLI::ValidationError("--fps",
                                       str(a.fps, ": a GIF shows at most 100 frames a second"));
        }
        return;
    }
    const std::string ext = fs::path(a.output).extension().string();
    if (ext != ".png" && ext != ".tif" && ext != ".tiff" && ext != ".jpg" && ext != ".exr") {
        throw CLI::ValidationError(
            "--at", str(a.output, ": --at writes one image (.png, .tif, .jpg, .exr)"));
    }
}

// With --auto: the face landmarks of both images when each holds a face (or --faces), else flow
// and features.
bool face_points(const MorphArgs& a, const Image& ia, const Image& ib, morph::Correspondences& c,
                 nlohmann::json& report) {
    if (!morph::faces_available()) {
        if (a.faces) throw Error(str("--faces: ", morph::faces_missing()));
        return false;
    }
    const std::optional<morph::Face> fa = morph::find_face(ia), fb = morph::find_face(ib);
    for (const auto& [face, name] : {std::pair{&fa, &a.a}, std::pair{&fb, &a.b}}) {
        if (!*face) {
            if (a.faces) {
                throw Error(str(*name,
                                ": no face found; give point files (--points-a, "
                                "--points-b) or leave out --faces"));
            }
            warn(str("note: ", *name, ": no face found; using flow and features"));
            return false;
        }
        if ((*face)->found > 1) {
            warn(str("note: ", *name, ": ", (*face)->found, " faces; using the largest"));
        }
    }
    // Landmarks outside either image (a face cut by the edge) are left out in both.
    c = {};
    auto inside = [](Vec2 p, const Image& im) {
        return p.x >= 0 && p.x <= im.width && p.y >= 0 && p.y <= im.height;
    };
    for (size_t i = 0; i < fa->points.size(); ++i) {
        if (!inside(fa->points[i], ia) || !inside(fb->points[i], ib)) continue;
        c.a.push_back(fa->points[i]);
        c.b.push_back(fb->points[i]);
    }
    if (c.a.size() < fa->points.size()) {
        warn(str("note: ", fa->points.size() - c.a.size(), " of ", fa->points.size(),
                 " face landmarks lie outside an image (a face cut by its edge); left out"));
    }
    report["faces"] = {{"a", fa->found}, {"b", fb->found}, {"landmarks", c.a.size()}};
    return true;
}

}  // namespace

Points correspondences(const MorphArgs& a, const Image& ia, const Image& ib, nlohmann::json& report,
                       const Progress& progress) {
    Points p;
    morph::Correspondences& c = p.c;
    if (a.automatic && !face_points(a, ia, ib, c, report)) {
        const morph::Matches m = morph::auto_match(ia, ib, {.progress = progress});
        report["matches"] = {{"flow", m.from_flow},
                             {"features", m.from_features},
                             {"rejected_forward_backward", m.rejected_fb},
                             {"rejected_ransac", m.rejected_ransac}};
        c = {m.a, m.b};
        p.landmarks = false;
        if (c.a.size() < 3) {
            throw Error(str("automatic matching found ", c.a.size(),
                            " correspondences between the images; a mesh needs at least 3"));
        }
    } else if (!a.automatic) {
        c = {read_points(a.points_a), read_points(a.points_b)};
        report["snapped_to_border"] = morph::snap_to_border(c.a, ia.width, ia.height) +
                                      morph::snap_to_border(c.b, ib.width, ib.height);
    }
    const bool files = !a.automatic;
    morph::check_correspondences(c, ia.width, ia.height, ib.width, ib.height,
                                 files ? a.points_a : a.a, files ? a.points_b : a.b);
    return p;
}

morph::PairMeshes pair_meshes(const MorphArgs& a, const Points& p, const Image& ia,
                              const Image& ib) {
    const morph::Correspondences& c = p.c;
    if (!a.triangles.empty()) {
        const auto t = morph::parse_triangles(read_file(a.triangles), static_cast<int>(c.a.size()),
                                              a.triangles);
        try {
            return morph::triangles_pair(c, t, ia.width, ia.height, ib.width, ib.height);
        } catch (const Error& e) {
            throw Error(str(a.triangles, ": ", e.what()));
        }
    }
    const std::string spec = a.mesh.empty() ? (p.landmarks ? "triangulation" : "grid") : a.mesh;
    if (spec == "triangulation") {
        return morph::triangulated_pair(c, ia.width, ia.height, ib.width, ib.height);
    }
    return morph::fitted_pair(generated_mesh(spec, ia.width, ia.height), c, ib.width, ib.height);
}

namespace {

morph::Schedule schedule(const MorphArgs& a, int levels) {
    morph::Schedule s;
    if (!a.schedule_file.empty()) {
        s = morph::parse_schedule_json(read_file(a.schedule_file), a.schedule_file, levels);
    } else {
        s.kind = morph::parse_schedule_kind(a.schedule);
        if (!a.bands.empty()) s.levels = morph::parse_level_windows(a.bands, levels);
    }
    if (!a.shape.empty()) {
        const auto w = morph::parse_level_windows("0:" + a.shape, 1);
        s.shape = w[0];
    }
    return s;
}

// The frames' size: --size, or A's, or for a GIF at most kGifSide pixels a side (0 x 0: A's).
std::pair<int, int> morph_output_size(const MorphArgs& a, const Image& ia) {
    if (!a.size.empty()) return parse_cells(a.size, "--size");
    if (fs::path(a.output).extension() == ".gif" && a.at < 0 &&
        std::max(ia.width, ia.height) > kGifSide) {
        const double s = static_cast<double>(kGifSide) / std::max(ia.width, ia.height);
        return {std::max(1, static_cast<int>(std::lround(ia.width * s))),
                std::max(1, static_cast<int>(std::lround(ia.height * s)))};
    }
    return {0, 0};
}

// The frames of a sequence (--frames, --loop) into `sink` in order; returns how many. `progress`
// gets the part done; the caller finishes the sink.
int write_frames(const morph::Morph& morph, const morph::FrameOptions& fo, const MorphArgs& a,
                 int channels, FrameSink& sink, const std::function<void(double)>& progress) {
    // --loop: A to B and back, without showing B or A twice in a row.
    const int total = a.loop && a.frames > 1 ? 2 * a.frames - 2 : a.frames;
    // Frame k shows the step step_of(k) of the way out, at time_of(k).
    const auto step_of = [&](int k) { return k < a.frames ? k : 2 * (a.frames - 1) - k; };
    const auto time_of = [&](int k) {
        return a.frames == 1 ? 0.0 : static_cast<double>(step_of(k)) / (a.frames - 1);
    };
    // The way back shows the way out's frames 1 .. N - 2 again: they are kept (while they fit
    // within kLoopBytes) instead of rendered twice.
    const double frame_bytes = static_cast<double>(morph.width()) * morph.height() *
                               static_cast<double>(channels) * sizeof(float);
    const bool keep = total > a.frames && frame_bytes * (a.frames - 2) <= kLoopBytes;
    std::vector<Image> kept(keep ? a.frames : 0);
    // Frames are independent: one per core at a time, written in order (a kept frame has no
    // future: it is taken from `kept` when its turn comes).
    const int lanes = std::clamp(thread_count(), 1, 8);
    std::deque<std::future<Image>> pending;
    for (int k = 0, next = 0; k < total; ++k) {
        for (; next < total && next < k + lanes; ++next) {
            if (keep && next >= a.frames) {
                pending.emplace_back();
                continue;
            }
            pending.push_back(std::async(std::launch::async, [&morph, &fo, t = time_of(next)] {
                return morph.frame(t, fo);
            }));
        }
        progress(static_cast<double>(k) / total);
        const int step = step_of(k);
        Image frame = pending.front().valid() ? pending.front().get() : std::move(kept[step]);
        pending.pop_front();
        sink.write(frame);
        if (keep && k < a.frames && step >= 1 && step <= a.frames - 2) {
            kept[step] = std::move(frame);
        }
    }
    return total;
}

void run_morph(const MorphArgs& a) {
    const auto start = std::chrono::steady_clock::now();
    check_morph_output(a);
    if (a.frames < 1 && a.at < 0) throw CLI::ValidationError("--frames", "must be at least 1");
    check_output(a.output, a.overwrite, {a.a, a.b});
    const Image ia = read_input(a.a), ib = read_input(a.b);
    const auto [out_w, out_h] = morph_output_size(a, ia);
    const std::string size_name = a.size.empty() ? a.a : "--size " + a.size;
    morph::check_sample_estimate(size_name, out_w > 0 ? out_w : ia.width,
                                 out_h > 0 ? out_h : ia.height, a.density, a.levels);
    // The landmark model loads while the faces are detected (after the images: an unreadable
    // image is reported at once, not after the model's half second).
    if (a.automatic) morph::prepare_faces();
    nlohmann::json report = {{"a", a.a}, {"b", a.b}, {"output", a.output}};
    ProgressBar bar;
    // One bar over the whole job: matching, fitting, the morph's set-up, then the frames.
    const Progress progress = [&bar](double done, const char* stage) { bar.update(done, stage); };
    const int frames = a.at >= 0 ? 1 : a.frames;
    const double setup = 0.5 * 10 / (10.0 + frames);  // the set-up's share, about 10 frames' worth
    bar.update(0.0, "correspondences");
    Points points;
    morph::PairMeshes pair;
    try {
        points = correspondences(a, ia, ib, report, progress_range(progress, 0, 0.6 * setup));
        bar.update(0.6 * setup, "meshes");
        pair = pair_meshes(a, points, ia, ib);
    } catch (const Error& e) {
        // Automatic matching found too little for a mesh (unrelated images, a cut): the shapes
        // stay as they are and the bands still blend on their schedule. Faces, point files and
        // triangles are the user's word, and their errors stand.
        if (!a.automatic || a.faces || report.contains("faces") || !a.triangles.empty()) throw;
        const std::string spec = a.mesh.empty() || a.mesh == "triangulation" ? "grid" : a.mesh;
        pair = morph::rest_pair(generated_mesh(spec, ia.width, ia.height), ib.width, ib.height);
        points = {};
        report["at_rest"] = e.what();
        warn(str("note: ", a.a, " + ", a.b, ": ", e.what(),
                 "; no motion: the morph dissolves them band by band"));
    }
    report["correspondences"] = points.c.a.size();
    report["mesh"] = pair.description;
    report["dropped_points"] = pair.dropped;
    if (!pair.repair.empty()) {
        report["repair"] = pair.repair;
        warn("note: " + pair.repair);
    }
    morph::MorphOptions o{.levels = a.levels, .density = a.density};
    o.sampling = sampling_from_name(a.sampling);
    o.width = out_w;
    o.height = out_h;
    // GIFs stay small: at most kGifSide pixels a side unless --size says otherwise.
    if (a.size.empty() && out_w > 0) {
        warn(str("note: the GIF is ", out_w, "x", out_h, " (--size WxH for another size)"));
    }
    const int width = out_w > 0 ? out_w : ia.width, height = out_h > 0 ? out_h : ia.height;
    morph::check_samples(size_name, pair.a, width, height, o);
    // Schedules name the levels 0 (base) .. J.
    o.levels = morph::morph_levels(pair.a, width, height, o);
    o.schedule = schedule(a, o.levels + 1);
    o.progress = progress_range(progress, 0.7 * setup, setup);
    const morph::Morph morph(ia, ib, pair.a, pair.b, o);
    report["levels"] = morph.levels();
    report["samples"] = morph.samples();
    const morph::FrameOptions fo{.preview = a.preview};
    if (a.at >= 0) {
        write_image(morph.frame(a.at, fo), a.output);
    } else {
        FrameSink sink(a.output, morph.width(), morph.height(), a.fps, a.h264);
        const int total =
            write_frames(morph, fo, a, std::max(ia.channels(), 3), sink,
                         [&](double done) { bar.update(setup + (1 - setup) * done, "frames"); });
        sink.finish();
        report["frames"] = total;
    }
    bar.clear();
    report["seconds"] = seconds_since(start);
    if (a.json) {
        std::printf("%s\n", report.dump(2).c_str());
    } else {
        std::printf("%s + %s -> %s: %s, J=%d, %lld samples, %.2f s\n", a.a.c_str(), a.b.c_str(),
                    a.output.c_str(), pair.description.c_str(), morph.levels(),
                    static_cast<long long>(morph.samples()), report["seconds"].get<double>());
    }
}

void add_schedule_options(CLI::App* cmd, MorphArgs& a) {
    cmd->add_option("--schedule", a.schedule,
                    "Band schedule: aware (corresponding detail kept sharp, the rest handed over "
                    "without doubling), linear (the classic warp and dissolve), bands or sharp")
        ->capture_default_str()
        ->check(CLI::IsMember({"aware", "linear", "bands", "sharp"}));
    cmd->add_option("--bands", a.bands, "Per-level windows for 'bands': LEVEL:START-END,...");
    cmd->add_option("--schedule-file", a.schedule_file, "Schedule as JSON (see README)");
    cmd->add_option("--shape", a.shape, "Geometry timing window START-END (default 0-1)");
    cmd->add_option("--density", a.density, "Mesh samples per output pixel")
        ->capture_default_str()
        ->check(density_range());
    cmd->add_option("-J,--levels", a.levels, "Mesh level J (default from --density)")
        ->check(CLI::Range(1, 10));
    add_sampling_option(cmd, a.sampling);
    cmd->add_flag("-y,--overwrite", a.overwrite, "Overwrite outputs");
    cmd->add_flag("--json", a.json, "Print a JSON report");
}

}  // namespace

void add_morph_commands(CLI::App& app) {
    auto a = std::make_shared<MorphArgs>();
    CLI::App* cmd =
        app.add_subcommand("morph", "Morph between two images (bands blended on schedules)");
    cmd->add_option("a", a->a, "First image")->required();
    cmd->add_option("b", a->b, "Second image")->required();
    cmd->add_option("-o,--output", a->output,
                    "out.mp4 or .mov (H.264), .mkv (lossless FFV1), .y4m, .gif, a folder for PNG "
                    "frames, or an image with --at")
        ->required();
    auto* points_a =
        cmd->add_option("--points-a", a->points_a, "Points on A: 'x y' lines or a JSON list");
    auto* points_b =
        cmd->add_option("--points-b", a->points_b, "The corresponding points on B, same order");
    points_a->needs(points_b);
    points_b->needs(points_a);
    cmd->add_option("--triangles", a->triangles, "Triangles over the points: 'i j k' lines")
        ->needs(points_a);
    cmd->add_flag("--auto", a->automatic,
                  str("Find correspondences: face landmarks when both images hold a face",
                      morph::faces_available() ? "" : " (not in this build: dlib is missing)",
                      ", else dense flow + features; the default without point files"))
        ->excludes(points_a);
    cmd->add_flag("--faces", a->faces,
                  "Use face landmarks (dlib, 68 points + forehead) or fail when a face is missing")
        ->excludes(points_a);
    cmd->add_option("--mesh", a->mesh,
                    "triangulation (default with points and faces), grid[:CxR] or voronoi[:N] "
                    "fitted with Ceres (default with flow and features)");
    cmd->add_option("--frames", a->frames, "Number of frames from A to B")
        ->capture_default_str()
        ->check(CLI::Range(1, 100000));
    cmd->add_option("--fps", a->fps, "Frames per second of MP4/GIF output (a GIF: at most 100)")
        ->capture_default_str()
        ->check(CLI::Range(0.1, 1000.0));
    cmd->add_flag("--loop", a->loop, "A to B and back to A (2N - 2 frames)");
    add_h264_options(cmd, a->h264);
    cmd->add_option("--at", a->at, "Only the frame at this t, to an image")
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_flag("--preview", a->preview, "Render from the coarse bands only (fast look-ups)");
    cmd->add_option("--size", a->size, "Output size WxH (default: A's)");
    add_schedule_options(cmd, *a);
    cmd->callback([a, cmd] {
        refuse_unused(*cmd, {"--frames", "--fps", "--loop", "--crf", "--preset"}, a->at < 0,
                      "a clip, not to the one frame of --at");
        refuse_unused(*cmd, {"--crf", "--preset"}, is_h264_output(a->output),
                      ".mp4/.mov output only");
        refuse_unused(*cmd, {"--fps"}, !FrameSink::is_folder_path(a->output),
                      "video and GIF output, not to PNG frames");
        a->automatic = a->automatic || a->faces || a->points_a.empty();
        run_morph(*a);
    });

    add_compare_morph_command(app);

    struct InbetweenArgs {
        std::string f0, f1, output, schedule = "linear", shape;
        double at = 0.5;
        morph::InbetweenOptions options;
        bool overwrite = false, json = false;
    };
    auto b = std::make_shared<InbetweenArgs>();
    cmd = app.add_subcommand("inbetween",
                             "The frame between two frames, from automatic correspondences");
    cmd->add_option("f0", b->f0, "First frame")->required();
    cmd->add_option("f1", b->f1, "Second frame")->required();
    cmd->add_option("-o,--output", b->output, "Output image")->required()->check(image_output());
    cmd->add_option("--at", b->at, "Time of the frame between 0 and 1")
        ->capture_default_str()
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_option("--cell", b->options.cell, "Grid cell size of the fitted mesh, pixels")
        ->capture_default_str()
        ->check(CLI::Range(2.0, 1000.0));
    cmd->add_option("--schedule", b->schedule, "Band schedule: linear, aware, bands or sharp")
        ->capture_default_str()
        ->check(CLI::IsMember({"linear", "aware", "bands", "sharp"}));
    cmd->add_option("--shape", b->shape, "Geometry timing window START-END (default 0-1)");
    cmd->add_option("--density", b->options.morph.density, "Mesh samples per output pixel")
        ->capture_default_str()
        ->check(density_range());
    cmd->add_flag("-y,--overwrite", b->overwrite, "Overwrite the output");
    cmd->add_flag("--json", b->json, "Print a JSON report");
    cmd->callback([b] {
        const auto start = std::chrono::steady_clock::now();
        check_output(b->output, b->overwrite, {b->f0, b->f1});
        morph::InbetweenOptions o = b->options;
        o.morph.schedule.kind = morph::parse_schedule_kind(b->schedule);
        if (!b->shape.empty())
            o.morph.schedule.shape = morph::parse_level_windows("0:" + b->shape, 1)[0];
        std::string note;
        const Image f0 = read_input(b->f0), f1 = read_input(b->f1);
        Image out;
        try {
            out = morph::inbetween(f0, f1, b->at, o, &note);
        } catch (const Error& e) {
            throw Error(str(b->f0, " + ", b->f1, ": ", e.what()));
        }
        if (!note.empty()) warn(str("note: ", b->f0, " + ", b->f1, ": ", note));
        write_image(out, b->output);
        const double seconds = seconds_since(start);
        if (b->json) {
            std::printf("%s\n", nlohmann::json{{"f0", b->f0},
                                               {"f1", b->f1},
                                               {"output", b->output},
                                               {"at", b->at},
                                               {"cell", o.cell},
                                               {"density", o.morph.density},
                                               {"note", note},
                                               {"seconds", seconds}}
                                    .dump(2)
                                    .c_str());
            return;
        }
        std::printf("%s + %s -> %s: t = %g, %g px cells, %.2f s\n", b->f0.c_str(), b->f1.c_str(),
                    b->output.c_str(), b->at, o.cell, seconds);
    });
}

}  // namespace tesswave::cli
