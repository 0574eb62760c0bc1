// The encoder's mesh motion on its own: tracks of a known pan pinned to the mesh and fitted, a cut
// that asks for a new group, and flat content that holds the mesh.
#include "video/enc_motion.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/math/grid_mesh.h"
#include "samples/sample_clip.h"
#include "video/mesh_motion.h"

namespace tesswave::video {
namespace {

Mesh rest_mesh(int width, int height) {
    Mesh m = grid_mesh(width, height, 8, 6);
    m.vertices = round_to_motion_unit(m.vertices);
    return m;
}

TEST(EncMotion, a_pan_moves_the_interior_vertices_by_the_pan) {
    const samples::SampleClipOptions o{.pan = {1.25, 0.5}, .object = false};
    const Mesh rest = rest_mesh(o.width, o.height);
    MeshMotion motion(rest, {});
    motion.track(samples::sample_clip_frame(o, 0));
    motion.pin(rest.vertices, true);
    std::vector<Vec2> vertices = rest.vertices;
    for (int t = 1; t <= 4; ++t) {
        motion.track(samples::sample_clip_frame(o, t));
        const MotionStep step = motion.fit(vertices);
        ASSERT_TRUE(step.vertices) << "frame " << t << ": " << step.failure;
        EXPECT_GE(step.tracks, 12);
        // The border slides and the corners are fixed, so points near the border lag a pan and
        // the residual grows with it (0.4 to 1.3 px here); it stays under the new-group limit.
        EXPECT_LT(step.rms, MeshMotionOptions{}.max_median) << "frame " << t;
        vertices = *step.vertices;
        motion.pin(vertices, false);
    }
    // Interior vertices follow the content: 4 frames of (1.25, 0.5).
    std::vector<double> error;
    for (size_t i = 0; i < rest.vertices.size(); ++i) {
        const Vec2 r = rest.vertices[i];
        if (r.x < 40 || r.x > o.width - 40 || r.y < 30 || r.y > o.height - 30) continue;
        error.push_back(std::hypot(vertices[i].x - r.x - 5.0, vertices[i].y - r.y - 2.0));
    }
    ASSERT_GT(error.size(), 4u);
    std::sort(error.begin(), error.end());
    EXPECT_LT(error[error.size() / 2], 0.1)
        << "median error of the interior vertices, px";  // 0.035
}

TEST(EncMotion, a_cut_asks_for_a_new_group_and_flat_content_holds_the_mesh) {
    const samples::SampleClipOptions a{.seed = 1}, b{.seed = 2};
    const Mesh rest = rest_mesh(a.width, a.height);
    MeshMotion motion(rest, {});
    motion.track(samples::sample_clip_frame(a, 0));
    motion.pin(rest.vertices, true);
    motion.track(samples::sample_clip_frame(b, 1));  // another scene
    const MotionStep cut = motion.fit(rest.vertices);
    EXPECT_FALSE(cut.vertices);
    EXPECT_FALSE(cut.hold);
    EXPECT_FALSE(cut.failure.empty());

    MeshMotion flat_motion(rest, {});
    const Image flat = make_image(a.width, a.height, 3);
    flat_motion.track(flat);
    flat_motion.pin(rest.vertices, true);
    flat_motion.track(flat);
    const MotionStep held = flat_motion.fit(rest.vertices);
    EXPECT_FALSE(held.vertices);
    EXPECT_TRUE(held.hold);
    EXPECT_TRUE(held.failure.empty()) << held.failure;
}

}  // namespace
}  // namespace tesswave::video
