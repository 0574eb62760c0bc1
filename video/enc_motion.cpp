#include "enc_motion.h"

#include <algorithm>

#include "core/math/error.h"
#include "core/math/strings.h"
#include "core/math/validate.h"
#include "mesh_motion.h"

namespace tesswave::video {

MeshPins::MeshPins(const Mesh& rest, const MeshMotionOptions& options)
    : rest_(rest), options_(options) {}

MeshMotion::MeshMotion(const Mesh& rest, const MeshMotionOptions& options)
    : options_(options), tracker_(options.tracker), pins_(rest, options) {}

void MeshMotion::track(const Image& frame) {
    last_live_ = tracks_ ? tracks_->size() : 0;
    tracks_ = &tracker_.next(frame);
    carried_ = static_cast<size_t>(
        std::count_if(tracks_->begin(), tracks_->end(), [](const Track& t) { return !t.born; }));
}

std::vector<Vec2> expected_positions(const Mesh& rest, std::span<const Vec2> last,
                                     std::span<const Vec2> before) {
    std::vector<Vec2> ahead(last.begin(), last.end());
    if (before.empty()) return ahead;
    for (size_t i = 0; i < ahead.size(); ++i) {
        const Vec2 p = 2.0 * last[i] - before[i];
        ahead[i] = {std::clamp(p.x, 0.0, rest.width), std::clamp(p.y, 0.0, rest.height)};
    }
    if (validate(rest, ahead, {.max_problems = 1}).ok()) return ahead;
    return {last.begin(), last.end()};
}

std::optional<std::vector<Vec2>> step_positions(const Mesh& rest, const MotionStep& step,
                                                std::span<const Vec2> last, std::string& failure) {
    if (step.hold) return std::vector<Vec2>(last.begin(), last.end());
    if (!step.vertices) {
        failure = step.failure;
        return std::nullopt;
    }
    std::vector<Vec2> v = round_to_motion_unit(*step.vertices);
    if (!validate(rest, v, {.max_problems = 1}).ok()) {
        failure = "the mesh is invalid at the file's 1/4-pixel precision";
        return std::nullopt;
    }
    return v;
}

Vec2 median_step(std::span<const Track> tracks) {
    std::vector<double> x, y;
    for (const Track& t : tracks) {
        if (t.born) continue;
        x.push_back(t.position.x - t.previous.x);
        y.push_back(t.position.y - t.previous.y);
    }
    if (x.size() < 3) return {};
    const auto median = [](std::vector<double>& v) {
        const auto middle = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
        std::nth_element(v.begin(), middle, v.end());
        return *middle;
    };
    return {median(x), median(y)};
}

std::string MeshMotion::cut() const {
    const double threshold = options_.min_carried * static_cast<double>(last_live_);
    if (last_live_ >= 8 &&  // a handful, so that a few lost tracks on flat content are no cut
        static_cast<double>(carried_) < threshold) {
        return str("a cut: ", carried_, " of ", last_live_, " tracks carried over");
    }
    return {};
}

MotionStep MeshMotion::fit(std::span<const Vec2> previous) const {
    MotionStep step;
    step.failure = cut();
    return step.failure.empty() ? pins_.fit(*tracks_, previous) : step;
}

MotionStep MeshPins::fit(std::span<const Track> tracks, std::span<const Vec2> previous,
                         Vec2 offset) const {
    MotionStep step;
    std::vector<Vec2> a, b;
    for (const Track& t : tracks) {
        if (t.born) continue;
        const auto it = rest_point_.find(t.id);
        if (it == rest_point_.end()) continue;
        a.push_back(it->second);
        b.push_back(t.position + offset);
    }
    step.tracks = static_cast<int>(a.size());
    if (step.tracks < options_.min_tracks) {
        step.hold = true;
        return step;
    }
    MeshFitOptions o;
    o.rigidity_weight = options_.rigidity_weight;
    o.smoothness_weight = options_.smoothness_weight;
    o.previous = previous;
    o.temporal_weight = options_.temporal_weight;
    o.step_tolerance = options_.fit_step_tolerance;
    const MeshFitResult r = fit_mesh(rest_, a, b, rest_.width, rest_.height, o);
    if (!r.ok()) {
        step.failure = r.failure;
        return step;
    }
    step.rms = r.rms;
    // The median residual: tracks on independently moving objects are outliers of the mesh's
    // motion, not failures of the fit.
    std::vector<double> residuals = r.residuals;
    const auto middle = residuals.begin() + static_cast<std::ptrdiff_t>(residuals.size() / 2);
    std::nth_element(residuals.begin(), middle, residuals.end());
    if (*middle > options_.max_median) {
        step.failure = str("median fit residual ", *middle, " px exceeds ", options_.max_median);
        return step;
    }
    for (int f = 0; f < rest_.num_faces(); ++f) {
        if (face_signed_area(rest_, r.vertices, f) <
            options_.min_area_ratio * face_signed_area(rest_, f)) {
            step.failure =
                str("face ", f, " shrank below ", options_.min_area_ratio, " of its rest area");
            return step;
        }
    }
    step.vertices = std::move(r.vertices);
    return step;
}

void MeshMotion::pin(std::span<const Vec2> vertices, bool restart) {
    pins_.pin(*tracks_, vertices, restart);
}

void MeshPins::pin(std::span<const Track> tracks, std::span<const Vec2> vertices, bool restart,
                   Vec2 offset) {
    if (restart) rest_point_.clear();
    std::vector<int64_t> ids;
    std::vector<Vec2> points;
    std::unordered_map<int64_t, Vec2> kept;
    for (const Track& t : tracks) {
        const auto it = rest_point_.find(t.id);
        if (it != rest_point_.end()) {
            kept.emplace(t.id, it->second);
        } else {
            ids.push_back(t.id);
            points.push_back(t.position + offset);
        }
    }
    const auto pins = pin_points(rest_, vertices, points);
    for (size_t i = 0; i < pins.size(); ++i) {
        if (pins[i]) kept.emplace(ids[i], pinned_position(rest_, rest_.vertices, *pins[i]));
    }
    rest_point_ = std::move(kept);
}

}  // namespace tesswave::video
