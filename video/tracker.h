// Feature tracks for the moving mesh (DESIGN.md 4): KLT tracking of Shi-Tomasi corners with a
// forward-backward check, and re-detection where the tracks thin out.
//
// Per frame: the previous frame's tracks are followed by pyramidal Lucas-Kanade (OpenCV
// calcOpticalFlowPyrLK) into the new frame and back again; a track survives when LK converges
// both ways, its new position lies inside the frame, and the backward-tracked position lands
// within max_fb_error pixels of where it started (Kalal et al., "Forward-Backward Error", 2010),
// and the LK windows at the old and new positions correlate (normalised cross-correlation over
// the window's part inside the frame >= min_ncc). The FB check alone misses most tracks on
// occluding boundaries: a window that straddles two motions converges to a compromise both ways;
// the correlation check catches them (on the sample clip, 1 - NCC is ~0.003 on clean tracks and
// ~0.1 on the boundary).
// Then the frame is split into cell x cell squares; where a square holds fewer than per_cell live
// tracks, new Shi-Tomasi corners are added (as goodFeaturesToTrack: local maxima of the smaller
// eigenvalue of the 3x3 structure tensor above quality times the frame's strongest; refined by
// cornerSubPix), at least min_distance pixels from every live track, up to max_tracks in all:
// in rounds that give each short cell one corner, strongest first, so that a tight budget
// spreads the tracks over the frame.
// Positions follow the project's convention: pixel (i,k) has its centre at (i+1/2, k+1/2).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/image.h"

namespace tesswave::video {

struct TrackerOptions {
    int max_tracks = 500;
    int cell = 32;              // pixels; the re-detection grid
    int per_cell = 3;           // wanted live tracks per cell
    double quality = 0.01;      // Shi-Tomasi: relative to the strongest corner in the frame
    double min_distance = 6;    // pixels between a new corner and any live track
    int window = 21;            // LK window side, pixels
    int pyramid_levels = 3;     // LK pyramid levels above the full-size one
    double max_fb_error = 0.5;  // pixels
    double min_ncc = 0.97;      // of the LK windows before and after; -1 disables the check
};

struct Track {
    int64_t id = 0;      // unique over the tracker's life; kept while the track lives
    Vec2 position = {};  // in the current frame
    bool born = false;   // detected in this frame (no previous position)
    Vec2 previous = {};  // position in the previous frame when !born
};

// What happened to the tracks in the last call of next().
struct TrackerStats {
    int tracked = 0;      // tracks followed from the previous frame (before the checks below)
    int lost_flow = 0;    // LK failed to converge (forward or backward)
    int lost_border = 0;  // left the frame
    int lost_fb = 0;      // failed the forward-backward check
    int lost_ncc = 0;     // failed the correlation check
    int born = 0;         // new detections
};

class Tracker {
  public:
    // Throws Error for impossible options.
    explicit Tracker(const TrackerOptions& options = {});
    ~Tracker();
    Tracker(Tracker&&) noexcept;
    Tracker& operator=(Tracker&&) noexcept;

    // First frame: detect; later frames: track from the previous frame, check, re-detect.
    // Returns the live tracks. Frames are RGB (or grey) float images of one size; a frame of
    // another size, or a malformed one, throws Error (and changes nothing).
    const std::vector<Track>& next(const Image& frame);

    // Forget the tracks and the previous frame: the next frame is a first frame again (a new
    // group of frames, or a clip of another size). Ids keep increasing.
    void reset();

    const std::vector<Track>& tracks() const;
    const TrackerStats& stats() const;
    int frame_index() const;  // frames given to next() since construction, minus one

  private:
    struct State;
    std::unique_ptr<State> state_;
};

}  // namespace tesswave::video
