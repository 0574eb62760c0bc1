#include "video/tracker.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <vector>

#include "core/math/error.h"
#include "samples/sample_clip.h"

namespace tesswave::video {
namespace {

using samples::sample_clip_frame;
using samples::sample_clip_motion;
using samples::sample_clip_object;
using samples::SampleClipOptions;

double percentile(std::vector<double> v, double q) {
    if (v.empty()) return NAN;
    const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
    std::nth_element(v.begin(), v.begin() + k, v.end());
    return v[k];
}

int carried(const std::vector<Track>& tracks) {
    return static_cast<int>(
        std::count_if(tracks.begin(), tracks.end(), [](const Track& t) { return !t.born; }));
}

// The fraction of the 32-pixel cells lying wholly inside the frame that hold a track.
double covered_cells(const std::vector<Track>& tracks, int width, int height) {
    const int nx = width / 32, ny = height / 32;
    std::set<int> cells;
    for (const Track& t : tracks) {
        const int cx = static_cast<int>(t.position.x / 32),
                  cy = static_cast<int>(t.position.y / 32);
        if (cx < nx && cy < ny) cells.insert(cy * nx + cx);
    }
    return static_cast<double>(cells.size()) / (nx * ny);
}

// A whole clip through the tracker: the errors of the carried tracks against the background's
// true motion, and per frame the live count, the cell coverage and the tracker's stats.
struct ClipRun {
    std::vector<double> errors;
    std::vector<int> live;
    std::vector<double> coverage;
    std::vector<TrackerStats> stats;
};

ClipRun track_clip(const SampleClipOptions& clip, const TrackerOptions& options = {}) {
    Tracker tracker(options);
    ClipRun run;
    std::map<int64_t, Vec2> last;  // id -> position in the previous frame
    int64_t max_id = -1;
    for (int t = 0; t < clip.frames; ++t) {
        const auto& tracks = tracker.next(sample_clip_frame(clip, t));
        EXPECT_EQ(tracker.frame_index(), t);
        std::map<int64_t, Vec2> now;
        for (const Track& k : tracks) {
            EXPECT_TRUE(now.emplace(k.id, k.position).second) << "duplicate id " << k.id;
            EXPECT_GE(k.position.x, 0);
            EXPECT_GE(k.position.y, 0);
            EXPECT_LT(k.position.x, clip.width);
            EXPECT_LT(k.position.y, clip.height);
            if (k.born) {
                EXPECT_GT(k.id, max_id) << "a new track reuses an id";
                continue;
            }
            if (last.count(k.id) == 0) {
                ADD_FAILURE() << "carried track " << k.id << " was not live";
                continue;
            }
            EXPECT_TRUE(last[k.id] == k.previous) << "previous position of " << k.id;
            run.errors.push_back(norm(k.position - sample_clip_motion(clip, t - 1, t, k.previous)));
        }
        for (const Track& k : tracks) max_id = std::max(max_id, k.id);
        EXPECT_EQ(tracker.stats().born + carried(tracks), static_cast<int>(tracks.size()));
        last = std::move(now);
        run.live.push_back(static_cast<int>(tracks.size()));
        run.coverage.push_back(covered_cells(tracks, clip.width, clip.height));
        run.stats.push_back(tracker.stats());
    }
    return run;
}

TEST(Tracker, pan_tracks_follow_the_true_motion) {
    const SampleClipOptions clip = {.frames = 12, .pan = {1.25, 0.5}, .object = false};
    const ClipRun run = track_clip(clip);
    ASSERT_GT(run.errors.size(), 900u);  // about 100 tracks a frame
    EXPECT_LT(percentile(run.errors, 0.5), 0.1);
    EXPECT_LT(percentile(run.errors, 0.95), 0.5);
}

TEST(Tracker, zoom_tracks_follow_the_true_motion) {
    const SampleClipOptions clip = {
        .frames = 12, .pan = {0.5, -0.25}, .zoom = 0.01, .object = false};
    const ClipRun run = track_clip(clip);
    ASSERT_GT(run.errors.size(), 900u);
    EXPECT_LT(percentile(run.errors, 0.5), 0.2);
    EXPECT_LT(percentile(run.errors, 0.95), 0.5);
}

// A fast pan moves a third of the frame out of view in 12 frames: the tracks that leave are
// replaced where new content enters, so the count and the coverage hold.
TEST(Tracker, redetection_replaces_tracks_that_leave) {
    const SampleClipOptions clip = {.frames = 12, .pan = {4, 2}, .object = false};
    const ClipRun run = track_clip(clip);
    int left = 0, born = 0;
    for (size_t t = 1; t < run.stats.size(); ++t) {
        left += run.stats[t].lost_border;
        born += run.stats[t].born;
        EXPECT_GE(run.live[t], 0.9 * run.live[0]) << "frame " << t;
        EXPECT_GE(run.coverage[t], 0.9) << "frame " << t;
    }
    EXPECT_GT(run.live[0], 70);  // 6x5 cells of 3 tracks on a 176x144 frame
    EXPECT_GT(left, 20);
    EXPECT_GE(born, left);
    EXPECT_LT(percentile(run.errors, 0.5), 0.1);
    EXPECT_LT(percentile(run.errors, 0.95), 0.5);
}

// Tracks whose window straddles the moving disk's rim see two motions; most are dropped, and
// the survivors follow one of the two true motions.
TEST(Tracker, occluding_boundary_loses_most_tracks) {
    const SampleClipOptions clip = {.frames = 12};
    Tracker tracker;
    std::vector<Track> before;
    int rim = 0, rim_kept = 0, clear = 0, clear_kept = 0;
    std::vector<double> rim_errors;
    for (int t = 0; t < clip.frames; ++t) {
        const auto& tracks = tracker.next(sample_clip_frame(clip, t));
        const auto a = sample_clip_object(clip, t - 1), b = sample_clip_object(clip, t);
        std::map<int64_t, Vec2> now;
        for (const Track& k : tracks) now[k.id] = k.position;
        for (const Track& k : before) {
            const double d = std::abs(norm(k.position - a.centre) - a.radius);
            const auto it = now.find(k.id);
            if (d > 15) {
                ++clear;
                clear_kept += it != now.end();
            } else if (d <= 10) {
                ++rim;
                if (it == now.end()) continue;
                ++rim_kept;
                const Vec2 background = sample_clip_motion(clip, t - 1, t, k.position);
                const Vec2 object = k.position + (b.centre - a.centre);
                rim_errors.push_back(
                    std::min(norm(it->second - background), norm(it->second - object)));
            }
        }
        before = tracks;
    }
    ASSERT_GT(rim, 30);
    EXPECT_LT(rim_kept, 0.5 * rim);
    EXPECT_GT(clear_kept, 0.9 * clear);
    EXPECT_LT(percentile(rim_errors, 1.0), 0.5);
}

// Frame 3 of `clip` with the columns x >= from_x taken from another scene.
Image spliced(const SampleClipOptions& clip, int from_x) {
    SampleClipOptions other = clip;
    other.seed = clip.seed + 6;
    Image frame = sample_clip_frame(clip, 3);
    const Image cut = sample_clip_frame(other, 3);
    for (int c = 0; c < 3; ++c) {
        for (int y = 0; y < frame.height; ++y) {
            for (int x = from_x; x < frame.width; ++x) frame.at(c, x, y) = cut.at(c, x, y);
        }
    }
    return frame;
}

TEST(Tracker, scene_cut_leaves_almost_no_tracks) {
    const SampleClipOptions clip = {.object = false};
    Tracker tracker;
    for (int t = 0; t < 3; ++t) tracker.next(sample_clip_frame(clip, t));
    const size_t live = tracker.tracks().size();
    ASSERT_GT(live, 70u);
    const auto& after = tracker.next(spliced(clip, 0));
    EXPECT_LE(carried(after), 0.05 * live);
    EXPECT_GE(tracker.stats().born, 0.8 * live);  // the new scene gets its own tracks
}

TEST(Tracker, half_changed_frame_loses_the_changed_half) {
    const SampleClipOptions clip = {.object = false};
    Tracker tracker;
    for (int t = 0; t < 3; ++t) tracker.next(sample_clip_frame(clip, t));
    const std::vector<Track> before = tracker.tracks();
    const int half = clip.width / 2;
    const auto& after = tracker.next(spliced(clip, half));
    std::set<int64_t> kept;
    for (const Track& k : after) {
        if (!k.born) kept.insert(k.id);
    }
    int left = 0, left_kept = 0, right = 0, right_kept = 0;
    for (const Track& k : before) {
        // Away from the seam by half a window plus the motion.
        if (k.position.x < half - 12) {
            ++left;
            left_kept += static_cast<int>(kept.count(k.id));
        } else if (k.position.x > half + 12) {
            ++right;
            right_kept += static_cast<int>(kept.count(k.id));
        }
    }
    ASSERT_GT(left, 30);
    ASSERT_GT(right, 30);
    EXPECT_GE(left_kept, 0.9 * left);
    EXPECT_LE(right_kept, 0.1 * right);
}

// Under a tight budget the new corners go to the emptiest cells first.
TEST(Tracker, max_tracks_caps_and_spreads_the_tracks) {
    const SampleClipOptions clip = {.object = false};
    Tracker tracker({.max_tracks = 20});
    const auto& tracks = tracker.next(sample_clip_frame(clip, 0));
    ASSERT_EQ(tracks.size(), 20u);
    std::map<int, int> cells;  // cell -> tracks; sub-pixel refinement may cross a cell's edge
    for (const Track& k : tracks) {
        ++cells[static_cast<int>(k.position.y / 32) * 8 + static_cast<int>(k.position.x / 32)];
    }
    EXPECT_GE(cells.size(), 18u);
    for (const auto& [cell, n] : cells) EXPECT_LE(n, 2) << "cell " << cell;
    EXPECT_LE(tracker.next(sample_clip_frame(clip, 1)).size(), 20u);
}

TEST(Tracker, frames_smaller_than_the_window) {
    for (const int size : {1, 2, 7, 13, 20}) {
        Tracker tracker;
        const SampleClipOptions clip = {.width = size, .height = size + 1};
        for (int t = 0; t < 3; ++t) {
            for (const Track& k : tracker.next(sample_clip_frame(clip, t))) {
                EXPECT_GE(k.position.x, 0);
                EXPECT_LT(k.position.x, size);
            }
        }
    }
}

TEST(Tracker, flat_frames_bad_frames_and_reset) {
    EXPECT_THROW(Tracker({.window = 1}), Error);
    EXPECT_THROW(Tracker({.max_fb_error = 0}), Error);
    EXPECT_THROW(Tracker({.min_ncc = 1.5}), Error);
    Tracker tracker;
    EXPECT_EQ(tracker.frame_index(), -1);
    Image flat = make_image(64, 48, 3);
    for (auto& plane : flat.planes) std::fill(plane.begin(), plane.end(), 0.5f);
    EXPECT_TRUE(tracker.next(flat).empty());
    const SampleClipOptions clip = {.width = 64, .height = 48};
    EXPECT_FALSE(tracker.next(sample_clip_frame(clip, 0)).empty());
    EXPECT_THROW(tracker.next(sample_clip_frame({.width = 65, .height = 48}, 0)), Error);
    Image broken = sample_clip_frame(clip, 1);
    broken.planes[2].pop_back();
    EXPECT_THROW(tracker.next(broken), Error);
    EXPECT_THROW(tracker.next(Image{}), Error);
    EXPECT_EQ(tracker.frame_index(), 1);

    int64_t max_id = -1;
    for (const Track& k : tracker.tracks()) max_id = std::max(max_id, k.id);
    tracker.reset();
    EXPECT_TRUE(tracker.tracks().empty());
    const auto& fresh = tracker.next(sample_clip_frame({.width = 96, .height = 64}, 0));
    ASSERT_FALSE(fresh.empty());
    for (const Track& k : fresh) {
        EXPECT_TRUE(k.born);
        EXPECT_GT(k.id, max_id);
    }
    EXPECT_EQ(tracker.frame_index(), 2);
}

}  // namespace
}  // namespace tesswave::video
