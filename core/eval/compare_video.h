// The pieces of `tesswave compare-video`: the seven methods, one coded and measured run of a clip
// at one rate (compare_video_run.cpp), and the report on all runs (compare_video_report.cpp).
#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/codec/twi_format.h"
#include "core/io/frame_source.h"
#include "core/math/image.h"
#include "core/math/progress.h"
#include "core/math/project.h"

namespace tesswave::eval {

enum class VideoMethod : uint8_t { moving_mesh, static_mesh, grid53, grid97, snow, vc2, x264 };

inline constexpr VideoMethod kVideoMethods[] = {
    VideoMethod::moving_mesh, VideoMethod::static_mesh, VideoMethod::grid53, VideoMethod::grid97,
    VideoMethod::snow,        VideoMethod::vc2,         VideoMethod::x264};
// The methods BD-rates are measured against (those of them that ran): our fixed grid, and the
// peers to beat.
inline constexpr VideoMethod kBdReferences[] = {VideoMethod::grid53, VideoMethod::snow,
                                                VideoMethod::x264};

const char* method_id(VideoMethod m);     // for --methods: "moving", "static", "grid53", ...
const char* method_label(VideoMethod m);  // for tables and plots: "moving mesh", "grid 5/3", ...
// Throws Error naming --methods for an unknown id.
VideoMethod method_from_id(const std::string& id);

// A clip as the comparison codes it: its first `frames` frames.
struct ClipInfo {
    std::string path, name, stem;  // stem: unique among the clips, used in file names
    int width = 0, height = 0;
    double fps = 25;
    int64_t frames = 0;
    int64_t shown_frame = 0;  // the frame in the side-by-side pictures
    bool chroma_420 = false;  // the source's chroma is subsampled: ours code it one level coarser
    // A video file's codec (FFmpeg's name) and bits a pixel (0: unknown); "" for folders, raw YUV.
    std::string source_codec{};
    double source_bpp = 0;
    double pixels() const { return static_cast<double>(width) * height * frames; }
};

// "" or a one-line note for a clip whose source was coded by a lossy block-transform codec: a
// peer of the same kind (x264 on H.264) can code the source's own blocks again, near-exactly at
// rates near the source's, which no other method can (chaplin.mp4, H.264 at 0.086 bpp: the moving
// mesh against x264 +112 % as it is, +39 % on a crop 3 and 5 pixels off its block grid).
std::string source_note(const ClipInfo& clip);

// Everything a run needs besides the method and the rate.
struct RunContext {
    const ClipInfo* clip = nullptr;
    FrameSourceOptions source;
    int group = 33;           // intra period of every method (snow's and x264's gop)
    std::string scratch_dir;  // where our .twv streams live while they are decoded
    // Called as the run proceeds: fraction of this run done, and what it is doing.
    Progress progress;
    Sampling sampling = Sampling::fit;  // how our mesh methods put frames on the mesh
    // The moving mesh codes every group on the mesh (else a group is also coded on the fixed-grid
    // 9/7 and kept there when better; the static mesh method always keeps the mesh).
    bool mesh_only = false;
    MeshWavelet mesh_wavelet = MeshWavelet::lattice97;  // the transform of our meshes' samples
};

struct VideoRow {
    std::string clip, method, rate;  // rate: the item of --rates
    double target_bpp = 0, bpp = 0, kbps = 0;
    int64_t bytes = 0, frames = 0;
    double psnr_y = 0, psnr = 0, ssim = 0;  // means over the frames
    double encode_s = -1, decode_s = -1;    // ours only (< 0: not measured apart)
    double total_s = 0;                     // encode and decode together
    std::string setting;  // the knob that was set: "kbps 12.5", "qscale 3.71", "crf 27.4"
    int tries = 1;        // encodes of a quality search
    std::string error;    // non-empty: the run failed, and why
};

// PSNR of BT.601 luma, Y = 0.299 R + 0.587 G + 0.114 B, computed from the 8-bit RGB samples
// that metrics.h compares, so that every method's Y comes from its RGB output in the same way.
// Capped at 100 dB (x264's convention) so that means over frames stay finite.
double luma_psnr(const Image& reference, const Image& test);

// Codes the clip's frames with `method` at `target_bpp` (bits per pixel, every frame counted),
// decodes them and measures against the clip. `shown` receives the decoded frame
// clip.shown_frame. A codec's failure comes back as a row with `error` set.
VideoRow run_video_method(const RunContext& context, VideoMethod method, double target_bpp,
                          Image* shown);

// Bjontegaard rate deltas of one method against one of kBdReferences on one clip, in percent,
// from the achieved bpp and the mean PSNR-Y and PSNR; NaN with the reason where it cannot be
// computed.
struct BdRow {
    std::string clip, method, reference;
    double psnr_y = 0, psnr = 0;
    std::string why_not_y, why_not;
};

std::vector<BdRow> bd_rates(const std::vector<ClipInfo>& clips, const std::vector<VideoRow>& rows,
                            const std::vector<VideoMethod>& methods);
std::string results_csv(const std::vector<VideoRow>& rows);
std::string bd_csv(const std::vector<BdRow>& bd);
nlohmann::json results_json(const std::vector<ClipInfo>& clips, const std::vector<VideoRow>& rows,
                            const std::vector<BdRow>& bd, const nlohmann::json& settings);
std::string summary_table(const std::vector<ClipInfo>& clips, const std::vector<VideoRow>& rows,
                          const std::vector<BdRow>& bd);
// PSNR-Y and PSNR (all channels) against bpp, one line per method, two panels side by side.
Image rd_plot(const ClipInfo& clip, const std::vector<VideoRow>& rows,
              const std::vector<VideoMethod>& methods);

}  // namespace tesswave::eval
