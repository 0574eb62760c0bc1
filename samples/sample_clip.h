// A procedural video clip with known motion: a camera pan and zoom over an infinite textured
// scene, plus an optional textured disk moving on a known path, so that trackers and the video
// codec can be checked against the true motion. Deterministic for a given seed.
//
// Camera: the background point seen at p in frame 0 is at M_t(p) = C + s^t (p - C) + t pan in
// frame t, with C the frame centre and s = 1 + zoom (the scene moves by `pan` pixels per frame and
// grows by the factor s per frame about the centre). The scene is a function of continuous
// coordinates (smooth shading, clouds, disks, bars, fine value noise) whose edges are ramped over
// one pixel; each pixel is the box average of 2x2 samples, so sub-pixel motion is rendered
// faithfully. The object is a rigid textured disk of fixed radius that translates along an
// ellipse about the frame centre (one turn per 96 frames), in front of the background.
#pragma once

#include <cstdint>

#include "core/math/geometry.h"
#include "core/math/image.h"

namespace tesswave::samples {

struct SampleClipOptions {
    int width = 176;
    int height = 144;
    int frames = 24;  // the clip's length for writers; the functions accept any frame index
    double fps = 25;
    Vec2 pan = {1.25, 0.5};  // background motion, pixels per frame
    double zoom = 0;         // relative scale change per frame about the centre (0.004: zoom in)
    bool object = true;
    uint32_t seed = 1;
};

// The moving disk in one frame; radius 0 when the clip has none. A point of the object at q in
// frame t is at q + centre(t') - centre(t) in frame t'.
struct SampleClipObject {
    Vec2 centre = {};
    double radius = 0;
};

// Frame t: RGB float, width x height, values in [0,1]. Throws Error for bad options.
Image sample_clip_frame(const SampleClipOptions& options, int t);

// Where the background point seen at p in frame 0 is in frame t: M_t(p) (exact).
Vec2 sample_clip_motion(const SampleClipOptions& options, int t, Vec2 p);

// Where the background point seen at p in frame `from` is in frame `to`: M_to(M_from^-1(p)).
Vec2 sample_clip_motion(const SampleClipOptions& options, int from, int to, Vec2 p);

// The object's disk in frame t.
SampleClipObject sample_clip_object(const SampleClipOptions& options, int t);

}  // namespace tesswave::samples
