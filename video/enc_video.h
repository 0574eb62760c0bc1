// The .twv encoder (DESIGN.md 4). Each group of frames shares one coding domain: a grid mesh T0
// (whose vertices follow the content, or stay put with motion none) or the fixed grid on the
// pixel lattice. Vertex motion is side information inside each frame chunk.
//
// By default a group is lifted (temporal.h): its frames' coefficients on the moving mesh are
// buffered, transformed along time with the 5/3, and every temporal band is coded as an embedded
// bit-plane stream. --kbps gives the group its share of the rate and cuts all its streams at one
// rate-distortion slope (allocation.h), so the rate lands on the target; --psnr quantizes every
// band with the step at which the group's mean PSNR (over all its frames) reaches the target, and
// keeps every bit-plane. A tracked group is also coded on the static mesh, a
// mesh group (grid_groups) on the fixed-grid 9/7 as well, and the best of the codings is kept;
// a tracked group whose camera pans is coded on a canvas and on the frame (enc_canvas.cpp).
// Frames come out of encode() when their group is coded (a group's length of latency).
//
// With low_delay, a group starts with an intra frame and every later frame codes the delta
// between its coefficients and the decoded coefficients of the frame before, closed loop: the
// encoder decodes its own bit-planes exactly as the decoder will, so errors never drift. --kbps
// then gives every frame a byte budget from a leaky bucket (an intra frame intra_weight times a
// delta frame's share). Either way each EncodedFrame's reconstruction equals the decoder's output
// bit for bit.
#pragma once

#include <array>
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
    // Mesh samples per pixel (mesh path). 1.5 against 2 (mesh alone, PSNR over all channels):
    // carphone 64 frames at 38 / 76 / 152 / 304 kbit/s +0.20 / +0.41 / +0.16 / +0.15 dB, Big
    // Buck Bunny 32 frames at 111 / 553 / 2212 kbit/s +0.42 / +0.10 / +0.07, aerial at 328 /
    // 1311 kbit/s +0.02 / -0.04; a quarter fewer samples. 1 lost up to 0.9 dB at high rates.
    double density = 1.5;
    int levels = 0;  // J (mesh) or decomposition levels (grid); 0: chosen
    // The transform of the mesh's samples (coding_domain.h). The 9/7 on the lattice of T_J
    // against the lifted bilinear wavelet, --mesh-only, PSNR-Y BD-rate against Snow in one run
    // each: aerial (32 frames) +9.9 % to -6.7 %, carphone (64) -7.5 % to -15.8 %, Big Buck Bunny
    // (64 at 640x360) -10.3 % to -18.6 %; 0.15 to 0.87 dB at every rate of the three. The 5/3 on
    // the lattice gave aerial +5.7 %: the 9/7's longer filters make most of the gain.
    MeshWavelet mesh_wavelet = MeshWavelet::lattice97;
    // Intra period: at most this many frames a group. 33 = 2^5 + 1 was chosen on the dyadic tree
    // (.twv version 3), where with 32 the second half of a group was predicted from one side
    // only and its last frames dipped by 2 to 4 dB (measured against 32 on 64 frames at 100 / 400
    // kbit/s: carphone +0.15 / +0.09 dB, chaplin +0.22 / +0.17). On the bisection tree every
    // length has every frame but the last between two others; 33 stays the intra period, the
    // one compare-video gives every method.
    int group = 33;
    bool low_delay = false;  // closed-loop deltas, one frame of latency, instead of lifting
    // Lifted groups: a frame within this PSNR (dB) of the last frame coded (a repeated frame, as
    // film transferred to a higher frame rate or animation on twos has) is not coded: that
    // frame's chunk says to show it again (0: never; with a quality target, at least 6 dB above
    // it). Every third of chaplin's frames repeats the one before at 43 to 59 dB (49.5 to 59 but
    // one); its first 64 frames at 300 / 1500 / 4600 kbit/s: 32.57 / 41.10 / 49.73 dB without
    // repeats, 32.81 / 42.00 / 50.41 at 45 (18 repeats), the same bytes (50 dB, before repeats
    // counted towards the group's length: 10 to 16 repeats, 0.3 to 0.1 dB less than 45).
    double repeat_psnr = 45;
    // Code chroma one level coarser (the finest detail bands of Cb and Cr are left out, so the
    // decoder's inverse transform upsamples them): for 4:2:0 sources.
    bool chroma_420 = false;
    double kbps = 0;  // rate target; > 0 overrides `quality`
    // Target PSNR in dB, when kbps is 0: of each group's frames on average (lifted), or of each
    // group's intra frame (low delay). The default is near the rates x264's default (CRF 23)
    // gives the shared clips, first 64 frames: carphone 0.099 bpp against x264's 0.119, chaplin
    // 0.057 against 0.084, aerial 0.39 against 0.31, Big Buck Bunny at 640x360 0.0066 against
    // 0.066 (the 9/7 on the mesh's lattice, the bisection tree; with the lifted wavelet and the
    // dyadic tree 0.121 / 0.058 / 0.55 / 0.0097; at density 2 without the grid candidate 0.126 /
    // 0.064 / 0.57 / 0.010, and 30 dB gave 0.073 / 0.033 / 0.20 / 0.008, 34 dB 0.159 / 0.079 /
    // 0.75 / 0.013).
    double quality = 33;
    double intra_weight = 4;  // low delay with a rate: an intra frame's share of a delta's
    // Mesh path, lifted groups: each group is also coded on the fixed-grid 9/7 and kept there
    // when that gives the lower error at the rate (with a quality target: the smaller group).
    bool grid_groups = true;
    MeshMotionOptions mesh_motion = {};
    // Tracked lifted groups whose camera pans are coded on a canvas (enc_canvas.cpp); false: on
    // the frame, the mesh stretching where new content enters.
    bool canvas = true;
    // How frames go on the mesh (project.h). The projection by default: with lifted groups it pays
    // at every rate (carphone, 96 frames, PSNR at 38 / 152 / 304 kbit/s: point 26.70 / 32.17 /
    // 33.87 dB, fit 26.93 / 33.04 / 35.34). With low-delay deltas it did not (30 frames at 150
    // kbit/s: point 29.87 dB, fit 29.38 to 29.90 at smoothness 0.01 to 0.3). Its smoothness,
    // measured at 0.02 / 0.1 / 0.8 bpp (carphone, 64 frames): 0.1 gives 24.75 / 31.49 / 37.76 dB,
    // 0.01 24.82 / 32.03 / 40.14, 0.003 24.92 / 32.08 / 40.25, 0 24.87 / 32.11 / 40.00; aerial at
    // 0.05 / 0.8 bpp: 0.1 26.12 / 33.14, 0.01 26.20 / 33.92, 0.003 26.20 / 33.94. Each frame's
    // projection starts from its point samples: starting from the previous frame's projection on
    // the moving mesh took more iterations (carphone, 32 frames: 13 to 21 a frame, against 10 to
    // 16), and from the point samples plus the previous frame's correction about as many (mean
    // 12.0 against 12.6), at equal time and PSNR; neither was kept. At most 4 steps a frame (the
    // tolerance would stop most frames at 10 to 16). PSNR with 30 / 8 / 4 / 2 steps: carphone, 32
    // frames, at 50 / 200 / 600 kbit/s: 28.83 / 28.84 / 28.82 / 28.83, 35.65 / 35.69 / 35.66 /
    // 35.58, 39.75 / 39.78 / 39.75 / 39.53; aerial, 16 frames, at 300 / 1500 / 4000: 29.34 /
    // 29.33 / 29.30 / 29.31, 34.45 / 34.46 / 34.47 / 34.41, 40.49 / 40.52 / 40.51 / 40.15; chaplin,
    // 16 frames, at 150 / 1500 (30 / 8 / 4): 28.39 / 28.39 / 28.39, 39.67 / 39.67 / 39.64. Point
    // sampling: carphone 28.48 / 33.13 / 34.89, aerial 28.89 / 32.52 / 34.57. From 8 steps to 4
    // (with the mesh fit's step tolerance, enc_motion.h), compare-video on 33 frames of each
    // shared clip at 0.02 to 0.8 bpp: the moving mesh's PSNR-Y moved by -0.020 to +0.018 dB
    // (static mesh: -0.041 to +0.042), its encoding 28 to 33 % faster.
    // Jacobi: the line preconditioner (project.h) gave the same quality in its 8 steps at 1.5
    // samples a pixel with this smoothness, and lost 0.01 to 0.04 dB and a fifth of the encoding
    // time (carphone, 64 frames, at 50 / 200 / 600 kbit/s).
    Sampling sampling = Sampling::fit;
    ProjectOptions projection = {
        .smoothness = 0.003, .max_iterations = 4, .preconditioner = Preconditioner::jacobi};
    // Within each encode() call: the fraction of that frame done and its stage (tracking, fitting
    // the mesh, calibrating, coding). The caller maps frames into its bar with progress_range.
    Progress progress = {};
};

struct EncodedFrame {
    int64_t number = 0;
    TwvFrameKind kind = TwvFrameKind::intra;
    bool first_in_group = false;
    bool static_group = false;  // a tracked clip's group coded better on the static mesh
    bool grid_group = false;    // a mesh clip's group coded better on the fixed grid
    bool canvas_group = false;  // a tracked group coded on a canvas (its camera pans)
    int64_t bytes = 0;          // everything written for it (group chunk included)
    int64_t motion_bytes = 0;   // vertex motion
    double psnr = 0;            // of reconstruction() against the input
    int tracks = 0;             // pinned tracks in the fit (tracked mesh)
    double fit_rms = 0;         // px
    bool repeat = false;        // shown as a copy of the frame before (repeat_psnr)
    std::string new_group;      // why this frame starts a group early (empty: it does not)
    double quality_target = 0;  // --psnr: the group's target, lowered where it is out of reach
    Image reconstruction;       // the decoder's image of the frame
    // The mesh the frame was coded on (none on the fixed grid): its topology, and its vertices in
    // the frame's pixels (a canvas reaches past the frame); and its tracks (tracked mesh).
    std::shared_ptr<const Mesh> mesh;
    std::vector<Vec2> vertices;
    std::vector<Track> live_tracks;
};

// The groups among coded frames, and those kept off the clip's own domain (a tracked clip's on
// the static mesh, a mesh clip's on the fixed grid).
struct GroupCount {
    int64_t groups = 0, static_groups = 0, grid_groups = 0, canvas_groups = 0;
    void add(const EncodedFrame& f) {
        if (!f.first_in_group) return;
        ++groups;
        canvas_groups += f.canvas_group;
        static_groups += f.static_group;
        grid_groups += f.grid_group;
    }
};

class VideoEncoder {
  public:
    // Writes to `path` through a temporary name; nothing appears there before finish(). Throws
    // Error for invalid options or sizes.
    VideoEncoder(const std::string& path, int width, int height, double fps,
                 const VideoEncodeOptions& options);
    ~VideoEncoder();

    // Takes one frame (width x height, 3 channels) and returns the frames this call coded, in
    // order: none while a lifted group fills, the whole group when it is complete or the frame
    // starts a new one; exactly this frame in low-delay mode.
    std::vector<EncodedFrame> encode(const Image& frame);
    // Codes the frames still buffered and returns them (finish() does it too, and drops them).
    std::vector<EncodedFrame> flush();

    // Writes the index and the trailer and renames the file into place. Returns its size.
    int64_t finish();
    // Of the finished file: the padding a very compressible clip needed (TwvLimits), in bytes.
    int64_t padding() const { return padding_; }
    const TwvHeader& header() const { return header_; }
    const TwvGroup& group() const { return group_; }

  private:
    // A frame shown as a copy of the pending frame before it (repeat_psnr): its image, for its
    // PSNR, and its description.
    struct Repeat {
        Image frame;
        EncodedFrame info;
    };
    // A frame of a lifted group, waiting for the group to be coded. A tracked group's frames
    // keep their tracks and the camera's offset (the frame's pixel p lies at p + offset in an
    // earlier pending frame's pixels; only differences count), and are fitted and analysed when
    // the group is complete.
    struct Pending {
        Image frame;
        Planes coefficients;
        std::vector<Vec2> vertices;  // in the frame's pixels
        std::vector<uint8_t> motion;
        EncodedFrame info;
        std::vector<Track> tracks = {};
        Vec2 offset = {};
        std::vector<Repeat> repeats = {};
        Planes still = {};  // tracked lifted groups: its samples on the static mesh, once made
    };
    // Whether `frame` repeats the last pending frame (and the group has room for it); if so it
    // is kept as a repeat of it.
    bool take_repeat(const Image& frame);
    // The frames the pending ones show: themselves and their repeats.
    int64_t pending_shown() const;
    using Window = std::array<int32_t, 2>;  // a frame's place on a canvas, in 1/4 pixels
    // A tracked lifted group's domain: on a canvas when its camera pans, with each frame's window.
    struct Canvas {
        TwvGroup group;
        std::shared_ptr<const CodingDomain> domain;
        std::vector<Window> windows = {};  // empty: all zero
    };
    // The pending frames on one domain: their positions (in the frames' pixels), motion and
    // coefficients; for a tracked group, each fit's pinned tracks and residual, and why the group
    // ends early (the fit of frame vertices.size() failed).
    struct GroupFrames {
        Canvas canvas;
        std::vector<std::vector<Vec2>> vertices = {};
        std::vector<std::vector<uint8_t>> motion = {};
        std::vector<Planes> coefficients = {};
        std::vector<int> tracks = {};
        std::vector<double> rms = {};
        std::string failure = {};
    };
    std::vector<EncodedFrame> encode_lifted_tracked(const Image& frame, EncodedFrame info);
    Canvas place_canvas() const;
    GroupFrames fit_group(Canvas canvas) const;
    void analyze_group(GroupFrames& frames) const;
    // The frame's samples on the static mesh into p.still, unless they are there already.
    void sample_still(Pending& p) const;
    // Codes the pending frames, in as many groups as their fits allow; with `keep_rest`, the
    // frames after the first group's failed fit stay pending as the next group's start.
    std::vector<EncodedFrame> code_pending(bool keep_rest = false);
    void start_group(int64_t number);
    EncodedFrame encode_low_delay(const Image& frame, EncodedFrame info, TwvFrame& f,
                                  uint64_t start);
    std::vector<uint8_t> code_frame(const Image& frame, TwvFrame& f, int64_t budget);
    // A lifted group coded one way (enc_group.cpp).
    struct GroupCoding {
        TwvGroup group;
        std::vector<TwvFrame> frames;
        std::vector<Image> images;  // the decoder's
        double squared_error = 0;
        size_t bytes = 0;
        float next_fine_step = 1.0f / 16;
        double quality_target = 0;  // --psnr: the group's
    };
    GroupCoding code_group(const CodingDomain& domain, const TwvGroup& base, std::vector<Planes> x,
                           const std::vector<std::vector<Vec2>>& vertices,
                           const std::vector<std::vector<uint8_t>>& motion, TwvMotion kind,
                           float fine_step, std::span<const Window> windows = {}) const;
    // Codes the pending group, on each of `meshes` (the tracked mesh on a canvas and on the
    // frame, or the clip's one domain) and the alternatives, and writes the best coding.
    std::vector<EncodedFrame> code_lifted_group(std::vector<GroupFrames> meshes);
    IntPlanes quantize_planes(const CodingDomain& domain, const Planes& r, float base_step) const;
    Planes requantized(const CodingDomain& domain, const Planes& x, float base_step) const;
    // The step for options_.quality, and the target used (lowered below a lower ceiling).
    struct QualityStep {
        float step = 1;
        double target = 0;
    };
    QualityStep step_for_quality(const std::function<double(float)>& psnr_at) const;
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
    std::shared_ptr<const CodingDomain> domain_;
    // grid_groups: the fixed grid each group is also coded on.
    std::shared_ptr<const CodingDomain> grid_domain_;
    TwvGroup grid_group_;
    std::unique_ptr<MeshMotion> motion_;
    TwvIndex index_;
    uint64_t written_ = 0;
    int64_t frames_ = 0, in_group_ = 0, group_length_ = 0;
    int64_t coded_frames_ = 0;           // frames written (their chunks, or a chunk they repeat)
    int64_t largest_group_bytes_ = 0;    // a lifted group's coefficients, for finish()
    int64_t largest_group_samples_ = 0;  // a mesh group's samples, for finish()
    int64_t padding_ = 0;
    float base_step_ = 1.0f / 1024;
    // Lifted groups with a rate: the step the streams are coded at, refined by quarters until the
    // group's cut falls inside them; on the mesh and on the fixed grid.
    float fine_step_[2] = {1.0f / 16, 1.0f / 16};
    std::vector<Pending> pending_;
    double quality_target_ = 0;
    Planes coefficients_, residual_;
    std::vector<Vec2> vertices_, previous_;
    Image reconstruction_;
};

}  // namespace tesswave::video
