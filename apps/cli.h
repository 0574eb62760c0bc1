// Shared plumbing of the tesswave subcommands: output checks, messages, JSON printing.
#pragma once

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <limits>
#include <string>
#include <vector>

#include "core/codec/twi_format.h"
#include "core/eval/analysis.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "frame_sink.h"

namespace tesswave::cli {

// Refuses to overwrite an existing output unless -y was given (as FFmpeg does), and refuses an
// output that is also an input.
void check_output(const std::string& path, bool overwrite,
                  const std::vector<std::string>& inputs = {});

// "mesh", "grid 5/3" or "grid 9/7", as reports print a transform.
const char* transform_name(TwiTransform t);

// Checks an output folder without creating it (call before any work, create when writing):
// refuses one that holds any of `inputs` (symlinks resolved), whose files it could replace, or
// with `overwrite` a hard link to one of them at any depth.
void check_folder(const std::string& dir, bool overwrite,
                  const std::vector<std::string>& inputs = {});

// An output folder: created if missing; an existing non-empty one needs -y (its files are then
// overwritten one by one, each atomically). Refuses a path that is a file, and one that holds
// any of `inputs` (as check_folder).
void prepare_folder(const std::string& dir, bool overwrite,
                    const std::vector<std::string>& inputs = {});

// An input image, with a one-line warning for what reading dropped: non-finite values (read as
// 0) and a decoder's complaint about a file it still read (a truncated JPEG).
Image read_input(const std::string& path, const ImageLimits& limits = {});

// Seconds since t on the steady clock (whole-command and per-stage timings in reports).
inline double seconds_since(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// -q: errors only (and --json output); -v: every stage on a line of its own, with its time.
enum class Verbosity { quiet, normal, verbose };
Verbosity& verbosity();

// A note or warning on stderr, one line ("warning: ..."), unless -q.
void warn(const std::string& line);

// A one-line progress bar on stderr, drawn only when stderr is a terminal; with -v, a line per
// stage instead (terminal or not); nothing with -q.
class ProgressBar {
  public:
    ProgressBar();
    ~ProgressBar();
    void update(double fraction, const char* stage);
    // Erases the bar (before the command's summary line, which would otherwise follow it on the
    // same terminal line); a later update draws it again.
    void clear();

  private:
    bool enabled_;
    int last_ = -1;
    std::string stage_;
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

// A check for options that must be a positive (finite) number: "must be <what>, not '<text>'".
CLI::Validator positive(const std::string& what);

// The kind of an output follows from its extension: a check that it is one of `extensions` (with
// their dots, any case), "<path>: <job> writes <kinds>" otherwise (exit 2, before any work).
CLI::Validator output_extension(std::vector<std::string> extensions, const std::string& job,
                                const std::string& kinds);
// An image output: an extension that OpenImageIO writes.
CLI::Validator image_output();

// "WxH" or "W x H" into two positive numbers; throws CLI::ValidationError naming the option.
std::pair<double, double> parse_size(const std::string& text, const std::string& option);
std::pair<int, int> parse_cells(const std::string& text, const std::string& option);

// A mesh file for an image: its domain must be the image's pixel rectangle, or with `fit` it is
// scaled to it. Validated; errors name the mesh file.
Mesh read_mesh_for(const std::string& mesh_path, const std::string& image_path, const Image& image,
                   bool fit);

// --mesh has one meaning in every subcommand, the tessellation: a mesh file (.json) or a
// generator, "grid[:CxR]" (a regular grid) or "voronoi[:N]" (Voronoi cells of N sites, seed 1,
// two Lloyd steps); without the count, cells of about 24 pixels.
bool is_mesh_generator(const std::string& spec);
Mesh generated_mesh(const std::string& spec, double width, double height);
// The mesh a --mesh SPEC gives for an image (`fit`: scale a file's domain to the image).
Mesh mesh_for(const std::string& spec, const std::string& image_path, const Image& image, bool fit);

// Refuses options the run would not use (given on the command line while `applies` is false),
// rather than ignoring them: "--crf: applies to .mp4/.mov output only" (exit 2). `when` says
// where the options apply.
void refuse_unused(const CLI::App& cmd, std::initializer_list<const char*> options, bool applies,
                   const std::string& when);

// True for an output path that FrameSink codes with H.264 (.mp4, .mov): where --crf and
// --preset apply.
bool is_h264_output(const std::string& path);

// --density has one range everywhere: samples per pixel in [0.01, 16].
inline CLI::Range density_range() { return CLI::Range(0.01, 16.0); }

// --max-pixels N on every decoder: accept images (and mesh samples) up to N whatever the file's
// size (and, for clips, any number of frames and groups up to TwvLimits::max_group_bytes); 0 keeps
// the default limits, which weigh a header's sizes and a clip's decoding work against the file's
// bytes.
inline CLI::Option* add_max_pixels_option(CLI::App* cmd, int64_t& value) {
    return cmd
        ->add_option("--max-pixels", value,
                     "Decode images (and mesh samples) up to this many whatever the file's size "
                     "(default: a small file may only claim a small image)")
        ->check(CLI::Range(int64_t{1}, int64_t{1} << 32));
}

// The limits a --max-pixels value gives (0: the defaults). It caps the pixels at N and trusts a
// file up to N, never less than the defaults trust any file.
template <class Limits>
Limits limits_for(int64_t max_pixels) {
    Limits l;
    if (max_pixels > 0) {
        l.max_pixels = max_pixels;
        l.free_pixels = std::max(l.free_pixels, max_pixels);
        if constexpr (requires { l.free_samples; })
            l.free_samples = std::max(l.free_samples, max_pixels);
        if constexpr (requires { l.free_work_pixels; }) {  // nor the work and a group's memory
            l.free_work_pixels = std::numeric_limits<int64_t>::max();
            l.free_group_bytes = l.max_group_bytes;
        }
    }
    return l;
}

// --sampling point|fit, one meaning on every command that puts an image on a mesh.
inline CLI::Option* add_sampling_option(CLI::App* cmd, std::string& value) {
    return cmd
        ->add_option("--sampling", value,
                     "How images go on the mesh: fit (the samples that render closest to the "
                     "image) or point (read at the sample positions)")
        ->capture_default_str()
        ->check(CLI::IsMember({"point", "fit"}));
}

// --mesh-wavelet 97|lifted, one meaning on every command that codes on a grid mesh (lossy).
inline CLI::Option* add_mesh_wavelet_option(CLI::App& cmd, std::string& value) {
    return cmd
        .add_option("--mesh-wavelet", value,
                    "Transform of a grid mesh's samples (lossy): 97 (the CDF 9/7 on the lattice "
                    "they form) or lifted (the paper's lifted bilinear wavelet)")
        ->capture_default_str()
        ->check(CLI::IsMember({"97", "lifted"}));
}

inline MeshWavelet mesh_wavelet_from_name(std::string_view name) {
    return name == "lifted" ? MeshWavelet::lifted : MeshWavelet::lattice97;
}

// --crf N and --preset P, one meaning wherever frames go to a FrameSink: how .mp4/.mov output
// is coded.
inline void add_h264_options(CLI::App* cmd, H264Settings& value) {
    cmd->add_option("--crf", value.crf,
                    "H.264 quality of .mp4/.mov output: 0 lossless .. 51 (x264's scale)")
        ->capture_default_str()
        ->check(CLI::Range(0, 51));
    cmd->add_option("--preset", value.preset,
                    "x264 speed preset of .mp4/.mov output (slower: smaller files)")
        ->capture_default_str()
        ->check(CLI::IsMember(std::vector<std::string>(kX264Presets.begin(), kX264Presets.end())));
}

// The analyze job, shared by `tesswave analyze` and the demo.
struct AnalyzeRequest {
    std::string image, mesh, output;  // mesh: a --mesh spec (empty: the paper's T0)
    bool fit_mesh = false;
    int levels = 0;                           // 0: from density
    double density = 3.5;                     // samples per pixel, the paper's figure
    std::vector<double> keep = {10, 1, 0.1};  // percentages of the detail coefficients
    std::string select = "paper";
    std::string sampling = "fit";
    bool overwrite = false;
    std::string mesh_description;
};
AnalysisResult run_analyze(const AnalyzeRequest& request);
void print_analysis_table(const AnalysisResult& result);

// The sample images and meshes, written into dir; returns the paths.
std::vector<std::string> write_samples(const std::string& dir, int width, int height);

// The video job of the demo: the clip coded with the moving mesh, the static mesh and the
// fixed-grid 5/3 at one rate, a table printed, the moving-mesh file decoded; returns the outputs.
std::vector<std::string> video_demo(const std::string& clip, const std::string& dir);

// Registers each subcommand on the app.
void add_mesh_commands(CLI::App& app);
void add_demo_command(CLI::App& app);
void add_analyze_command(CLI::App& app);
void add_samples_command(CLI::App& app);
void add_codec_commands(CLI::App& app);
void add_compare_command(CLI::App& app);
void add_compare_video_command(CLI::App& app);
void add_morph_commands(CLI::App& app);
void add_eval_interp_command(CLI::App& app);
void add_video_commands(CLI::App& app);
void add_info_command(CLI::App& app);

}  // namespace tesswave::cli
