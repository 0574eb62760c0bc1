#include "samples/sample_clip.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/math/error.h"
#include "core/math/sampling.h"

namespace tesswave::samples {
namespace {

double mean_abs_difference(const Image& a, const Image& b) {
    double sum = 0;
    for (int c = 0; c < 3; ++c) {
        for (size_t i = 0; i < a.planes[c].size(); ++i)
            sum += std::abs(a.planes[c][i] - b.planes[c][i]);
    }
    return sum / (3.0 * a.width * a.height);
}

struct Residual {
    double mean = 0, worst = 0;
};

// Frame t against frame `from` resampled (bilinear) where the true motion says each pixel of
// frame t came from, over the pixels for which `use` holds and the source lies 4 px inside.
template <class Use, class Source>
Residual compare_moved(const Image& frame, const Image& source, Use use, Source where) {
    std::vector<Vec2> positions;
    std::vector<size_t> pixels;
    for (int y = 0; y < frame.height; ++y) {
        for (int x = 0; x < frame.width; ++x) {
            const Vec2 q = {x + 0.5, y + 0.5};
            const Vec2 p = where(q);
            if (!use(q) || p.x < 4 || p.y < 4 || p.x > frame.width - 4 || p.y > frame.height - 4) {
                continue;
            }
            positions.push_back(p);
            pixels.push_back(static_cast<size_t>(y) * frame.width + x);
        }
    }
    EXPECT_GT(pixels.size(), 500u);
    const auto moved = sample_bilinear(source, positions);
    Residual r;
    for (int c = 0; c < 3; ++c) {
        for (size_t i = 0; i < pixels.size(); ++i) {
            const double d = std::abs(moved[c][i] - frame.planes[c][pixels[i]]);
            r.mean += d;
            r.worst = std::max(r.worst, d);
        }
    }
    r.mean /= 3.0 * pixels.size();
    return r;
}

TEST(SampleClip, deterministic_seeded_and_in_range) {
    const SampleClipOptions o = {.width = 64, .height = 48, .zoom = 0.004};
    const Image a = sample_clip_frame(o, 5), b = sample_clip_frame(o, 5);
    ASSERT_EQ(a.width, 64);
    ASSERT_EQ(a.height, 48);
    ASSERT_EQ(a.channels(), 3);
    EXPECT_EQ(a.planes, b.planes);
    for (const auto& plane : a.planes) {
        for (float v : plane) {
            ASSERT_GE(v, 0.0f);
            ASSERT_LE(v, 1.0f);
        }
    }
    SampleClipOptions other = o;
    other.seed = 2;
    EXPECT_GT(mean_abs_difference(a, sample_clip_frame(other, 5)), 0.05);
    EXPECT_GT(mean_abs_difference(a, sample_clip_frame(o, 6)), 0.02);  // it moves
}

TEST(SampleClip, whole_pixel_pan_shifts_frame_zero_exactly) {
    const SampleClipOptions o = {.width = 80, .height = 60, .pan = {2, -1}, .object = false};
    const Image f0 = sample_clip_frame(o, 0), f3 = sample_clip_frame(o, 3);
    const Vec2 m = sample_clip_motion(o, 3, {10.5, 20.5});
    EXPECT_DOUBLE_EQ(m.x, 16.5);
    EXPECT_DOUBLE_EQ(m.y, 17.5);
    double worst = 0;
    for (int c = 0; c < 3; ++c) {
        for (int y = 0; y + 3 < o.height; ++y) {
            for (int x = 6; x < o.width; ++x) {
                worst = std::max(worst, double(std::abs(f3.at(c, x, y) - f0.at(c, x - 6, y + 3))));
            }
        }
    }
    EXPECT_LT(worst, 1e-5);
}

TEST(SampleClip, subpixel_pan_and_zoom_match_the_motion_function) {
    const auto all = [](Vec2) { return true; };
    for (const double zoom : {0.0, 0.01}) {
        const SampleClipOptions o = {.width = 96, .height = 80, .zoom = zoom, .object = false};
        const Image f0 = sample_clip_frame(o, 0);
        for (const int t : {1, 3}) {
            const Image ft = sample_clip_frame(o, t);
            const Residual moved =
                compare_moved(ft, f0, all, [&](Vec2 q) { return sample_clip_motion(o, t, 0, q); });
            const Residual still = compare_moved(ft, f0, all, [](Vec2 q) { return q; });
            // Bilinear resampling is the only error left: small on the texture, and up to about
            // a tenth of the contrast across the one-pixel ramps of the edges.
            EXPECT_LT(moved.mean, 0.006) << "zoom " << zoom << " t " << t;
            EXPECT_LT(moved.worst, 0.12) << "zoom " << zoom << " t " << t;
            EXPECT_GT(still.mean, 5 * moved.mean) << "zoom " << zoom << " t " << t;
        }
    }
    // Motion from frame a to frame b composes: a -> b -> a is the identity.
    const SampleClipOptions o = {.pan = {0.7, -1.1}, .zoom = 0.02};
    const Vec2 p = {30.25, 99.5};
    const Vec2 q = sample_clip_motion(o, 3, 11, p);
    const Vec2 back = sample_clip_motion(o, 11, 3, q);
    EXPECT_NEAR(back.x, p.x, 1e-9);
    EXPECT_NEAR(back.y, p.y, 1e-9);
    EXPECT_GT(norm(q - p), 5);
}

TEST(SampleClip, object_moves_rigidly_along_its_path) {
    const SampleClipOptions o = {.width = 176, .height = 144};
    const int t = 7;
    const SampleClipObject a = sample_clip_object(o, t), b = sample_clip_object(o, t + 1);
    ASSERT_GT(a.radius, 15);
    EXPECT_EQ(a.radius, b.radius);
    const Vec2 step = b.centre - a.centre;
    EXPECT_GT(norm(step), 2);
    EXPECT_GT(norm(step - o.pan), 2);  // not moving with the background
    const Image fa = sample_clip_frame(o, t), fb = sample_clip_frame(o, t + 1);
    const auto on_object = [&](Vec2 q) { return norm(q - b.centre) < b.radius - 2; };
    const auto off_object = [&](Vec2 q) {
        return norm(q - b.centre) > b.radius + 2 &&
               norm(sample_clip_motion(o, t + 1, t, q) - a.centre) > a.radius + 2;
    };
    const Residual object = compare_moved(fb, fa, on_object, [&](Vec2 q) { return q - step; });
    const Residual wrong = compare_moved(fb, fa, on_object, [&](Vec2 q) { return q - o.pan; });
    const Residual background = compare_moved(
        fb, fa, off_object, [&](Vec2 q) { return sample_clip_motion(o, t + 1, t, q); });
    EXPECT_LT(object.mean, 0.006);
    EXPECT_LT(background.mean, 0.006);
    EXPECT_GT(wrong.mean, 5 * object.mean);
    // Without the object, the frame changes only on the disk.
    SampleClipOptions plain = o;
    plain.object = false;
    EXPECT_FALSE(sample_clip_object(plain, t).radius > 0);
    const Image fp = sample_clip_frame(plain, t);
    int changed = 0;
    for (int y = 0; y < o.height; ++y) {
        for (int x = 0; x < o.width; ++x) {
            if (fp.at(1, x, y) == fa.at(1, x, y)) continue;
            ++changed;
            ASSERT_LT(norm(Vec2{x + 0.5, y + 0.5} - a.centre), a.radius + 1) << x << "," << y;
        }
    }
    EXPECT_GT(changed, 0.9 * M_PI * a.radius * a.radius);
}

TEST(SampleClip, bad_options_throw) {
    EXPECT_THROW(sample_clip_frame({.width = 0}, 0), Error);
    EXPECT_THROW(sample_clip_frame({.height = 100000}, 0), Error);
    EXPECT_THROW(sample_clip_frame({.zoom = -1}, 0), Error);
    EXPECT_THROW(sample_clip_frame({.pan = {NAN, 0}}, 0), Error);
}

}  // namespace
}  // namespace tesswave::samples
