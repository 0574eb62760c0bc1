// The .twv encoder (DESIGN.md 4). Each group of frames shares one coding domain: a grid mesh T0
// (whose vertices follow the content, or stay put with motion none) or the fixed grid on the
// pixel lattice. A group starts with an intra frame; every later frame codes the delta between its
// coefficients and the decoded coefficients of the frame before, closed loop: the encoder decodes
// its own bit-planes exactly as the decoder will, so reconstruction() equals the decoder's output
// bit for bit and errors never drift. Vertex motion is side information inside each frame chunk.
//
// Rate control: --kbps gives every frame a byte budget from a leaky bucket (an intra frame
// intra_weight times a delta frame's share) and cuts its embedded stream there; --psnr picks
// the base step of each group by bisection so that its intra frame reaches the target PSNR, and
// keeps that step (every bit-plane coded) for the group's deltas.
#pragma once

#include <cstdint>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/math/image.h"
#include "core/math/progress.h"
#include "core/math/project.h"
#include "enc_motion.h"
#include "twv_domain.h"
#include "twv_format.h"

namespace tesswave::video {

struct VideoEncodeOptions {
    TwiTransform transform = TwiTransform::mesh;
    TwvMotion motion = TwvMotion::tracked;  // mesh path
    int motion_level = 0;  // the moving mesh is T_k of the base grid (k levels fewer above it)
    double density = 2.0;  // mesh samples per pixel (mesh path)
    int levels = 0;        // J (mesh) or decomposition levels (grid); 0: chosen
    int group = 32;        // intra period: at most this many frames a group
    double kbps = 0;       // rate target; > 0 overrides `quality`
    // Target PSNR in dB of each group's intra frame, when kbps is 0. The default puts the shared
    // clips near the rates x264's default (CRF 23) gives them: carphone 0.25 bpp against x264's
    // 0.12, aerial 0.41 against 0.31, chaplin 0.078 against 0.081, Big Buck Bunny at 640x360 0.018
    // against 0.066 (29 and 33 dB were further off).
    double quality = 30;
    double intra_weight = 4;
    MeshMotionOptions mesh_motion = {};
    // How frames go on the mesh (project.h). Point sampling by default: at the rates a video codec
    // runs at the projection does not pay (carphone, 30 frames, 150 kbit/s: point 29.87 dB; fit
    // 29.38 dB at smoothness 0.01, 29.47 at 0.03, 29.90 at 0.1, 29.53 at 0.3).
    Sampling sampling = Sampling::point;
    ProjectOptions projection = {.smoothness = 0.1};
    // Within each encode() call: the fraction of that frame done and its stage (tracking, fitting
    // the mesh, calibrating, coding). The caller maps frames into its bar with progress_range.
    Progress progress = {};
};

struct EncodedFrame {
    int64_t number = 0;
    TwvFrameKind kind = TwvFrameKind::intra;
    int64_t bytes = 0;          // everything written for it (group chunk included)
    int64_t motion_bytes = 0;   // vertex motion
    double psnr = 0;            // of reconstruction() against the input
    int tracks = 0;             // pinned tracks in the fit (tracked mesh)
    double fit_rms = 0;         // px
    std::string new_group;      // why this frame starts a group early (empty: it does not)
    double quality_target = 0;  // --psnr: the group's target, lowered where it is out of reach
};

class VideoEncoder {
  public:
    // Writes to `path` through a temporary name; nothing appears there before finish(). Throws
    // Error for invalid options or sizes.
    VideoEncoder(const std::string& path, int width, int height, double fps,
                 const VideoEncodeOptions& options);
    ~VideoEncoder();

    // Codes one frame (width x height, 3 channels).
    EncodedFrame encode(const Image& frame);
    // The decoder's image of the frame coded last.
    const Image& reconstruction() const { return reconstruction_; }
    // Of the frame coded last (mesh path): the mesh and its vertex positions, and the tracks.
    const Mesh* mesh() const;
    std::span<const Vec2> vertices() const { return vertices_; }
    const std::vector<Track>* tracks() const;

    // Writes the index and the trailer and renames the file into place. Returns its size.
    int64_t finish();
    const TwvHeader& header() const { return header_; }
    const TwvGroup& group() const { return group_; }

  private:
    void start_group(int64_t number);
    std::vector<uint8_t> code_frame(const Image& frame, TwvFrame& f, int64_t budget);
    void write(const std::vector<uint8_t>& bytes);
    float calibrate_step(const Image& frame);
    double frame_share(bool intra) const;
    int64_t frame_budget(bool intra, uint64_t spent) const;

    std::string path_, temporary_;
    std::ofstream out_;
    bool finished_ = false;
    VideoEncodeOptions options_;
    TwvHeader header_;
    TwvGroup group_;
    std::unique_ptr<CodingDomain> domain_;
    std::unique_ptr<MeshMotion> motion_;
    TwvIndex index_;
    uint64_t written_ = 0;
    int64_t frames_ = 0, in_group_ = 0;
    float base_step_ = 1.0f / 1024;
    double quality_target_ = 0;
    Planes coefficients_, residual_;
    std::vector<Vec2> vertices_, previous_;
    Image reconstruction_;
};

}  // namespace tesswave::video
