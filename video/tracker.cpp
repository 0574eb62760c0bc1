#include "tracker.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "core/io/opencv_image.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave::video {
namespace {

constexpr int kBorder = 3;  // pixels: no new corners this close to the frame's edge
const cv::TermCriteria kFlowStop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 1e-4);
const cv::TermCriteria kSubPixStop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-3);

void check(const TrackerOptions& o) {
    if (o.max_tracks < 1 || o.cell < 4 || o.per_cell < 1 || !(o.quality > 0 && o.quality < 1) ||
        !(o.min_distance >= 0) || o.window < 3 || o.pyramid_levels < 0 || o.pyramid_levels > 10 ||
        !(o.max_fb_error > 0) || !(o.min_ncc >= -1 && o.min_ncc <= 1)) {
        throw Error(str("tracker options: need max_tracks >= 1 (", o.max_tracks, "), cell >= 4 (",
                        o.cell, "), per_cell >= 1 (", o.per_cell, "), 0 < quality < 1 (", o.quality,
                        "), min_distance >= 0 (", o.min_distance, "), window >= 3 (", o.window,
                        "), pyramid_levels in 0..10 (", o.pyramid_levels, "), max_fb_error > 0 (",
                        o.max_fb_error, "), -1 <= min_ncc <= 1 (", o.min_ncc, ")"));
    }
}

// Normalised cross-correlation of the (2 half + 1)^2 windows around p in a and q in b (same
// size), over the offsets for which both lie inside the images; 1 when too little is inside to
// judge.
double window_ncc(const cv::Mat& a, const cv::Mat& b, cv::Point2f p, cv::Point2f q, int half) {
    const auto range = [half](float u, float v, int size) {
        const int lo =
            std::max({-half, static_cast<int>(std::ceil(-u)), static_cast<int>(std::ceil(-v))});
        const int hi = std::min({half, static_cast<int>(std::floor(size - 1 - u)),
                                 static_cast<int>(std::floor(size - 1 - v))});
        return std::pair{lo, hi};
    };
    const auto [x0, x1] = range(p.x, q.x, a.cols);
    const auto [y0, y1] = range(p.y, q.y, a.rows);
    if (x1 - x0 < 2 || y1 - y0 < 2) return 1;
    const cv::Size size(x1 - x0 + 1, y1 - y0 + 1);
    const cv::Point2f middle(0.5f * (x0 + x1), 0.5f * (y0 + y1));
    cv::Mat wa, wb;
    cv::getRectSubPix(a, size, p + middle, wa, CV_32F);
    cv::getRectSubPix(b, size, q + middle, wb, CV_32F);
    const double n = static_cast<double>(size.area());
    const double ma = cv::sum(wa)[0] / n, mb = cv::sum(wb)[0] / n;
    const double ab = wa.dot(wb) / n - ma * mb;
    const double aa = wa.dot(wa) / n - ma * ma, bb = wb.dot(wb) / n - mb * mb;
    return aa > 0 && bb > 0 ? ab / std::sqrt(aa * bb) : 0;
}

// OpenCV puts pixel (i,k)'s centre at (i,k); the project at (i+1/2, k+1/2).
cv::Point2f to_cv(Vec2 p) { return {static_cast<float>(p.x - 0.5), static_cast<float>(p.y - 0.5)}; }
Vec2 from_cv(cv::Point2f p) { return {p.x + 0.5, p.y + 0.5}; }

bool inside(Vec2 p, cv::Size size) {
    return p.x >= 0 && p.y >= 0 && p.x < size.width && p.y < size.height;
}

}  // namespace

struct Tracker::State {
    TrackerOptions options;
    cv::Size size;                 // of the frames; empty before the first
    std::vector<cv::Mat> pyramid;  // the previous frame's LK pyramid (with derivatives)
    std::vector<Track> tracks;
    TrackerStats stats;
    int64_t next_id = 0;
    int frame = -1;
    // Scratch, kept to avoid reallocation.
    cv::Mat grey, previous_grey, eig, peaks, blocked;
    std::vector<cv::Point2f> from, to, back;
    std::vector<uchar> status, status_back;
    std::vector<float> error;

    void track(const std::vector<cv::Mat>& current);
    std::vector<cv::Point> corners(const std::function<bool(cv::Point)>& want);
    void detect();
};

// Follows the live tracks from the previous pyramid into `current` and back; keeps the good ones.
void Tracker::State::track(const std::vector<cv::Mat>& current) {
    const cv::Size window(options.window, options.window);
    const int levels = options.pyramid_levels;
    from.clear();
    for (const Track& t : tracks) from.push_back(to_cv(t.position));
    stats.tracked = static_cast<int>(tracks.size());
    if (from.empty()) return;
    cv::calcOpticalFlowPyrLK(pyramid, current, from, to, status, error, window, levels, kFlowStop);
    cv::calcOpticalFlowPyrLK(current, pyramid, to, back, status_back, error, window, levels,
                             kFlowStop);
    size_t kept = 0;
    for (size_t i = 0; i < tracks.size(); ++i) {
        const Vec2 position = from_cv(to[i]);
        if (!status[i] || !status_back[i]) {
            ++stats.lost_flow;
        } else if (!inside(position, size)) {
            ++stats.lost_border;
        } else if (cv::norm(back[i] - from[i]) > options.max_fb_error) {
            ++stats.lost_fb;
        } else if (options.min_ncc > -1 && window_ncc(previous_grey, grey, from[i], to[i],
                                                      options.window / 2) < options.min_ncc) {
            ++stats.lost_ncc;
        } else {
            Track& t = tracks[kept++];
            t = {.id = tracks[i].id,
                 .position = position,
                 .born = false,
                 .previous = tracks[i].position};
        }
    }
    tracks.resize(kept);
}

// Local maxima of the smaller eigenvalue of the 3x3 structure tensor (Shi-Tomasi) above quality
// times the frame's maximum, in the cells that `want` one, strongest first.
std::vector<cv::Point> Tracker::State::corners(const std::function<bool(cv::Point)>& want) {
    cv::cornerMinEigenVal(grey, eig, 3, 3);
    double strongest = 0;
    cv::minMaxLoc(eig, nullptr, &strongest);
    const float threshold = static_cast<float>(options.quality * strongest);
    cv::dilate(eig, peaks, cv::Mat());
    std::vector<std::pair<float, cv::Point>> found;
    for (int y = kBorder; y < size.height - kBorder; ++y) {
        const float* e = eig.ptr<float>(y);
        const float* m = peaks.ptr<float>(y);
        for (int x = kBorder; x < size.width - kBorder; ++x) {
            if (e[x] > threshold && e[x] == m[x] && want({x, y})) found.push_back({e[x], {x, y}});
        }
    }
    std::stable_sort(found.begin(), found.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    std::vector<cv::Point> out(found.size());
    for (size_t i = 0; i < found.size(); ++i) out[i] = found[i].second;
    return out;
}

// Adds corners in the cells short of per_cell tracks, at least min_distance (rounded) from the
// live tracks and from each other. Round r admits a corner in cells holding fewer than r tracks,
// so that under the max_tracks budget the emptiest cells are served first.
void Tracker::State::detect() {
    const int budget = options.max_tracks - static_cast<int>(tracks.size());
    if (budget <= 0) return;
    const int cell = options.cell;
    const int nx = (size.width + cell - 1) / cell, ny = (size.height + cell - 1) / cell;
    const auto cell_of = [&](double x, double y) {
        const int cx = std::clamp(static_cast<int>(x / cell), 0, nx - 1);
        const int cy = std::clamp(static_cast<int>(y / cell), 0, ny - 1);
        return static_cast<size_t>(cy) * nx + cx;
    };
    std::vector<int> count(static_cast<size_t>(nx) * ny, 0);
    const int radius = static_cast<int>(std::lround(options.min_distance));
    blocked.create(size, CV_8UC1);
    blocked.setTo(0);
    for (const Track& t : tracks) {
        ++count[cell_of(t.position.x, t.position.y)];
        const cv::Point2f p = to_cv(t.position);
        cv::circle(blocked, {cvRound(p.x), cvRound(p.y)}, radius, 255, cv::FILLED);
    }
    const int per_cell = options.per_cell;
    if (std::all_of(count.begin(), count.end(), [&](int c) { return c >= per_cell; })) return;
    const std::vector<cv::Point> found =
        corners([&](cv::Point p) { return count[cell_of(p.x + 0.5, p.y + 0.5)] < per_cell; });
    std::vector<cv::Point2f> chosen;
    for (int round = 1; round <= per_cell; ++round) {
        for (const cv::Point p : found) {
            if (static_cast<int>(chosen.size()) == budget) break;
            int& c = count[cell_of(p.x + 0.5, p.y + 0.5)];
            if (c >= round || blocked.at<uint8_t>(p)) continue;
            ++c;
            chosen.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
            cv::circle(blocked, p, radius, 255, cv::FILLED);
        }
    }
    if (chosen.empty()) return;
    std::vector<cv::Point2f> refined = chosen;
    // cornerSubPix needs the frame to hold 2 half + 5 pixels each way.
    const int half = std::min(5, (std::min(size.width, size.height) - 5) / 2);
    if (half >= 1) cv::cornerSubPix(grey, refined, {half, half}, {-1, -1}, kSubPixStop);
    for (size_t i = 0; i < chosen.size(); ++i) {
        // cornerSubPix can wander off on blob-like features; keep the pixel then.
        const bool keep = cv::norm(refined[i] - chosen[i]) <= 0.5 * options.min_distance + 0.5 &&
                          inside(from_cv(refined[i]), size);
        tracks.push_back({.id = next_id++,
                          .position = from_cv(keep ? refined[i] : chosen[i]),
                          .born = true,
                          .previous = {}});
        ++stats.born;
    }
}

Tracker::Tracker(const TrackerOptions& options) : state_(std::make_unique<State>()) {
    check(options);
    state_->options = options;
}

Tracker::~Tracker() = default;
Tracker::Tracker(Tracker&&) noexcept = default;
Tracker& Tracker::operator=(Tracker&&) noexcept = default;

const std::vector<Track>& Tracker::next(const Image& frame) {
    State& s = *state_;
    const size_t n = static_cast<size_t>(std::max(frame.width, 0)) * std::max(frame.height, 0);
    if (frame.width < 1 || frame.height < 1 || frame.channels() < 1 ||
        std::any_of(frame.planes.begin(), frame.planes.end(),
                    [&](const auto& plane) { return plane.size() != n; })) {
        throw Error(str("tracker: frame ", s.frame + 1, " is not a valid image (", frame.width, "x",
                        frame.height, ", ", frame.channels(), " channels)"));
    }
    const cv::Size size(frame.width, frame.height);
    if (!s.size.empty() && size != s.size) {
        throw Error(str("tracker: frame ", s.frame + 1, " is ", frame.width, "x", frame.height,
                        ", the previous frames ", s.size.width, "x", s.size.height));
    }
    s.size = size;
    s.stats = {};
    grey8(frame, s.grey);
    try {
        std::vector<cv::Mat> current;
        cv::buildOpticalFlowPyramid(s.grey, current, {s.options.window, s.options.window},
                                    s.options.pyramid_levels, true, cv::BORDER_REFLECT_101,
                                    cv::BORDER_CONSTANT, false);
        if (!s.pyramid.empty()) s.track(current);
        s.detect();
        s.pyramid = std::move(current);
    } catch (const cv::Exception& e) {
        // Not expected for valid frames; the tracker starts over if the caller goes on.
        reset();
        throw Error(str("tracker: frame ", s.frame + 1, ": OpenCV failed: ", e.what()));
    }
    cv::swap(s.grey, s.previous_grey);
    ++s.frame;
    return s.tracks;
}

void Tracker::reset() {
    state_->pyramid.clear();
    state_->tracks.clear();
    state_->size = {};
    state_->stats = {};
}

const std::vector<Track>& Tracker::tracks() const { return state_->tracks; }
const TrackerStats& Tracker::stats() const { return state_->stats; }
int Tracker::frame_index() const { return state_->frame; }

}  // namespace tesswave::video
