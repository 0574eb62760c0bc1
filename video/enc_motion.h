// The encoder's mesh motion (DESIGN.md 4): KLT tracks pinned to parametric locations (face, quad,
// u, v) of the group's mesh, and per frame a Ceres fit of the T0 vertex positions that carries
// every pinned point to its tracked position, regularized towards the rest mesh (as-similar),
// smoothness and the expected positions (temporal). A cut (most tracks lost at once) or a failed
// fit asks for a new group instead of a broken mesh; content too flat to track holds the mesh.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/fit/mesh_fit.h"
#include "core/math/mesh.h"
#include "tracker.h"

namespace tesswave::video {

struct MeshMotionOptions {
    TrackerOptions tracker = {};
    double rigidity_weight = 0.1;
    double smoothness_weight = 0.1;
    double temporal_weight = 0.01;
    // px (MeshFitOptions::step_tolerance): positions are coded in quarter pixels. It took the
    // bench clip's fits from 15 to 9 steps on average (total 695 to 416 ms).
    double fit_step_tolerance = 0.05;
    int min_tracks = 12;        // fewer pinned tracks: the mesh holds still (flat content)
    double min_carried = 0.25;  // fewer of the last frame's tracks carried over: a cut, new group
    double max_median = 2.0;    // px; a fit whose median residual is worse: new group
    double min_area_ratio = 0.25;  // a face shrinking below this part of its rest area: new group
};

struct MotionStep {
    std::optional<std::vector<Vec2>> vertices;  // the fitted T0 positions, or none
    bool hold = false;    // none because too few tracks: keep the last positions
    std::string failure;  // else why none: the group must restart
    int tracks = 0;       // pinned tracks used
    double rms = 0;       // of the fit's inliers, px
};

// Where the temporal term pulls a frame's vertices: towards constant velocity from `before` to
// `last` (no lag on steady motion) when that extrapolation, held within the domain, is a valid
// mesh; else towards `last`. `before` empty: `last`.
std::vector<Vec2> expected_positions(const Mesh& rest, std::span<const Vec2> last,
                                     std::span<const Vec2> before);
// The positions a fit step gives on the motion grid: `last` when it holds, none (and `failure`
// says why) when it failed or its rounded positions are not a valid mesh.
std::optional<std::vector<Vec2>> step_positions(const Mesh& rest, const MotionStep& step,
                                                std::span<const Vec2> last, std::string& failure);

// The median step of the tracks carried from the frame before (x and y apart): the camera's pan;
// zero with fewer than 3.
Vec2 median_step(std::span<const Track> tracks);

// Tracks pinned to parametric locations of a mesh at rest, and the fit that carries each pinned
// point to its track. A frame's pixel p lies at p + `offset` on the mesh's domain (a canvas).
class MeshPins {
  public:
    MeshPins(const Mesh& rest, const MeshMotionOptions& options);

    // The frame's vertices from the pinned tracks among `tracks`, starting from `previous`.
    MotionStep fit(std::span<const Track> tracks, std::span<const Vec2> previous,
                   Vec2 offset = {}) const;
    // Pins the tracks without a pin (born this frame, or every track when `restart`, at a group
    // start) on the mesh at `vertices`, and forgets the pins of lost tracks.
    void pin(std::span<const Track> tracks, std::span<const Vec2> vertices, bool restart,
             Vec2 offset = {});

  private:
    Mesh rest_;
    MeshMotionOptions options_;
    std::unordered_map<int64_t, Vec2> rest_point_;  // per pinned track: its rest position
};

class MeshMotion {
  public:
    // `rest`: the group's mesh at its rest positions (every group starts there).
    MeshMotion(const Mesh& rest, const MeshMotionOptions& options);

    // Tracks `frame` (every frame, intra or not).
    void track(const Image& frame);
    // Why the frame tracked last cannot continue the group (most tracks lost at once: a cut), or
    // empty.
    std::string cut() const;
    // The current frame's vertices from the pinned tracks, starting from `previous`; a cut fails.
    MotionStep fit(std::span<const Vec2> previous) const;
    // Pins the current tracks (MeshPins::pin).
    void pin(std::span<const Vec2> vertices, bool restart);

    const std::vector<Track>& tracks() const { return *tracks_; }

  private:
    MeshMotionOptions options_;
    Tracker tracker_;
    MeshPins pins_;
    const std::vector<Track>* tracks_ = nullptr;
    size_t last_live_ = 0, carried_ = 0;  // tracks alive in the frame before, carried from it
};

}  // namespace tesswave::video
