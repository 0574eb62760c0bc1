#include "morph/auto_match.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <utility>

#include "core/io/opencv_image.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave::morph {
namespace {

constexpr int kMinSide = 16;
constexpr int kMinPriorInliers = 8;
constexpr double kMinPriorMotion = 2.0;  // pixels at a corner; less is left to the flow alone
constexpr int kWindow = 9;               // structure tensor and correlation window, as DIS's patch
constexpr int kFeatures = 2000;          // ORB keypoints per image
constexpr int kRefineWindow = 15;        // Lucas-Kanade window refining a feature match

// Working coordinates are OpenCV's (pixel centre at integers); DESIGN.md 2.1 adds 1/2.
constexpr double kCentre = 0.5;
// The most pixels of A that matching works on (2^21: 1920x1080 and smaller at full size).
constexpr int64_t kMatchPixels = int64_t{1} << 21;

void check_inputs(const Image& a, const Image& b, const AutoMatchOptions& o) {
    for (const auto& [image, name] : {std::pair{&a, "A"}, std::pair{&b, "B"}}) {
        bool planes_fit = image->channels() > 0;
        for (const auto& plane : image->planes) {
            planes_fit = planes_fit && plane.size() == static_cast<size_t>(image->width) *
                                                           static_cast<size_t>(image->height);
        }
        if (image->width < kMinSide || image->height < kMinSide || !planes_fit) {
            throw Error(str("auto_match: image ", name, " is ", image->width, "x", image->height,
                            " with ", image->channels(), " channels; need at least ", kMinSide, "x",
                            kMinSide, " pixels"));
        }
    }
    if (o.grid_step < 1 || !(o.fb_tolerance > 0) || !(o.ratio > 0 && o.ratio <= 1) ||
        !(o.ransac_px > 0) || o.max_points < 1 || !(o.min_texture >= 0) ||
        !(o.min_similarity <= 1)) {
        throw Error(str("auto_match: bad options (need grid_step ", o.grid_step,
                        " >= 1, fb_tolerance ", o.fb_tolerance, " > 0, ratio ", o.ratio,
                        " in (0,1], ransac_px ", o.ransac_px, " > 0, max_points ", o.max_points,
                        " >= 1, min_texture ", o.min_texture, " >= 0, min_similarity ",
                        o.min_similarity, " <= 1)"));
    }
}

struct Candidates {
    std::vector<cv::Point2f> a, b;  // after the ratio test; b on B's working copy
};

Candidates match_features(const cv::Mat& a8, const cv::Mat& b8, double ratio) {
    auto orb = cv::ORB::create(kFeatures);
    std::vector<cv::KeyPoint> ka, kb;
    cv::Mat da, db;
    orb->detectAndCompute(a8, cv::noArray(), ka, da);
    orb->detectAndCompute(b8, cv::noArray(), kb, db);
    Candidates out;
    if (ka.empty() || kb.size() < 2) return out;
    std::vector<std::vector<cv::DMatch>> knn;
    cv::BFMatcher(cv::NORM_HAMMING).knnMatch(da, db, knn, 2);
    for (const auto& m : knn) {
        if (m.size() == 2 && m[0].distance < ratio * m[1].distance) {
            out.a.push_back(ka[m[0].queryIdx].pt);
            out.b.push_back(kb[m[0].trainIdx].pt);
        }
    }
    return out;
}

const cv::Matx23d kIdentity(1, 0, 0, 0, 1, 0);

// A similarity by RANSAC, loose enough to take a smooth non-rigid residual among its inliers:
// the flow only needs it to bring the motion within reach. Identity when it is not trustworthy
// or too small to matter.
cv::Matx23d global_prior(const Candidates& c, cv::Size size, double ransac_px) {
    if (c.a.size() < kMinPriorInliers) return kIdentity;
    const double threshold = std::max(2 * ransac_px, 0.015 * std::hypot(size.width, size.height));
    std::vector<uint8_t> inliers;
    cv::Mat m = cv::estimateAffinePartial2D(c.a, c.b, inliers, cv::RANSAC, threshold, 2000, 0.995);
    if (m.empty() || std::count(inliers.begin(), inliers.end(), 1) < kMinPriorInliers) {
        return kIdentity;
    }
    const cv::Matx23d prior = m;
    double motion = 0;
    for (const auto& p :
         {cv::Vec3d(0, 0, 1), cv::Vec3d(size.width - 1, 0, 1), cv::Vec3d(0, size.height - 1, 1),
          cv::Vec3d(size.width - 1, size.height - 1, 1)}) {
        const cv::Vec2d q = prior * p;
        motion = std::max(motion, std::hypot(q[0] - p[0], q[1] - p[1]));
    }
    return motion < kMinPriorMotion ? kIdentity : prior;
}

cv::Point2f apply(const cv::Matx23d& m, cv::Point2f p) {
    return {static_cast<float>(m(0, 0) * p.x + m(0, 1) * p.y + m(0, 2)),
            static_cast<float>(m(1, 0) * p.x + m(1, 1) * p.y + m(1, 2))};
}

// Bilinear sample of a two-channel flow at p, which must lie in [0,w-1]x[0,h-1].
cv::Point2f sample(const cv::Mat& flow, cv::Point2f p) {
    const int x0 = std::min(static_cast<int>(p.x), flow.cols - 2);
    const int y0 = std::min(static_cast<int>(p.y), flow.rows - 2);
    const float fx = p.x - x0, fy = p.y - y0;
    const auto& f00 = flow.at<cv::Vec2f>(y0, x0);
    const auto& f10 = flow.at<cv::Vec2f>(y0, x0 + 1);
    const auto& f01 = flow.at<cv::Vec2f>(y0 + 1, x0);
    const auto& f11 = flow.at<cv::Vec2f>(y0 + 1, x0 + 1);
    const cv::Vec2f f = (1 - fy) * ((1 - fx) * f00 + fx * f10) + fy * ((1 - fx) * f01 + fx * f11);
    return {f[0], f[1]};
}

bool inside(cv::Point2f p, cv::Size size) {
    return p.x >= 0 && p.y >= 0 && p.x <= size.width - 1 && p.y <= size.height - 1;
}

// The smaller eigenvalue of the structure tensor (window mean of gradient products, grey in
// [0,1]): small on flat ground and along straight edges, where flow is a guess.
cv::Mat texture(const cv::Mat& a8) {
    cv::Mat gx, gy;
    cv::Sobel(a8, gx, CV_32F, 1, 0, 3, 1.0 / (8 * 255));
    cv::Sobel(a8, gy, CV_32F, 0, 1, 3, 1.0 / (8 * 255));
    cv::Mat xx = gx.mul(gx), yy = gy.mul(gy), xy = gx.mul(gy);
    for (cv::Mat* m : {&xx, &yy, &xy}) cv::boxFilter(*m, *m, -1, cv::Size(kWindow, kWindow));
    cv::Mat out(a8.size(), CV_32F);
    for (int y = 0; y < a8.rows; ++y) {
        for (int x = 0; x < a8.cols; ++x) {
            const float p = xx.at<float>(y, x), q = yy.at<float>(y, x), r = xy.at<float>(y, x);
            out.at<float>(y, x) = 0.5f * (p + q) - std::sqrt(0.25f * (p - q) * (p - q) + r * r);
        }
    }
    return out;
}

// Bilinear sample of an 8-bit image, edges clamped.
double sample(const cv::Mat& image, double x, double y) {
    x = std::clamp(x, 0.0, image.cols - 1.0);
    y = std::clamp(y, 0.0, image.rows - 1.0);
    const int x0 = std::min(static_cast<int>(x), image.cols - 2);
    const int y0 = std::min(static_cast<int>(y), image.rows - 2);
    const double fx = x - x0, fy = y - y0;
    const uint8_t* r0 = image.ptr<uint8_t>(y0) + x0;
    const uint8_t* r1 = image.ptr<uint8_t>(y0 + 1) + x0;
    return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}

// A displacement near pixel (x, y): u + (i - x) ux + (j - y) uy at pixel (i, j).
struct LocalMotion {
    cv::Vec2f u, ux = {}, uy = {};
};

// The flow's local affine map at (x, y): its value there and its central differences.
LocalMotion local_motion(const cv::Mat& flow, int x, int y) {
    constexpr int r = kWindow / 2;
    const int xl = std::max(x - r, 0), xh = std::min(x + r, flow.cols - 1);
    const int yl = std::max(y - r, 0), yh = std::min(y + r, flow.rows - 1);
    return {flow.at<cv::Vec2f>(y, x),
            (flow.at<cv::Vec2f>(y, xh) - flow.at<cv::Vec2f>(y, xl)) / (xh - xl),
            (flow.at<cv::Vec2f>(yh, x) - flow.at<cv::Vec2f>(yl, x)) / (yh - yl)};
}

// Zero-mean normalized cross-correlation of A's window at (x, y) with B's under an affine
// motion. Affine, not the flow itself: a per-pixel flow can paint A's pattern out of any
// texture in B.
double zncc(const cv::Mat& a8, const cv::Mat& b8, int x, int y, const LocalMotion& m) {
    constexpr int r = kWindow / 2;
    double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
    int n = 0;
    for (int j = std::max(y - r, 0); j <= std::min(y + r, a8.rows - 1); ++j) {
        for (int i = std::max(x - r, 0); i <= std::min(x + r, a8.cols - 1); ++i) {
            const cv::Vec2f d =
                m.u + static_cast<float>(i - x) * m.ux + static_cast<float>(j - y) * m.uy;
            const double va = a8.at<uint8_t>(j, i), vb = sample(b8, i + d[0], j + d[1]);
            sa += va, sb += vb, saa += va * va, sbb += vb * vb, sab += va * vb;
            ++n;
        }
    }
    const double va = saa - sa * sa / n, vb = sbb - sb * sb / n;
    return va > 0 && vb > 0 ? (sab - sa * sb / n) / std::sqrt(va * vb) : 0.0;
}

enum class Verdict { kept, flat, inconsistent, dissimilar };

// The dense field A -> B's working copy: the flow to the pre-warped copy, checked, then the
// prior.
struct Field {
    cv::Mat a8 = {}, texture = {}, warped = {}, forward = {}, backward = {};
    cv::Matx23d prior = kIdentity;
    const AutoMatchOptions* options = nullptr;

    // The image q of p on B's working copy, when the flow there is trustworthy.
    Verdict map(cv::Point2f p, cv::Point2f* q) const {
        const cv::Size size = forward.size();
        if (!inside(p, size)) return Verdict::inconsistent;
        const int x = static_cast<int>(std::lround(p.x)), y = static_cast<int>(std::lround(p.y));
        if (texture.at<float>(y, x) < options->min_texture) return Verdict::flat;
        const cv::Point2f ahead = p + sample(forward, p);
        if (!inside(ahead, size)) return Verdict::inconsistent;
        const cv::Point2f back = ahead + sample(backward, ahead);
        if (std::hypot(back.x - p.x, back.y - p.y) >= options->fb_tolerance) {
            return Verdict::inconsistent;
        }
        *q = apply(prior, ahead);
        if (q->x < -kCentre || q->y < -kCentre || q->x > size.width - kCentre ||
            q->y > size.height - kCentre) {
            return Verdict::inconsistent;
        }
        const bool alike =
            zncc(a8, warped, x, y, local_motion(forward, x, y)) >= options->min_similarity;
        return alike ? Verdict::kept : Verdict::dissimilar;
    }

    // A feature match (p, q) off the trusted field, refined by Lucas-Kanade on the pre-warped
    // copy (keypoints are whole pixels at best) and checked like a flow sample; false when it
    // drifts ransac_px or more or does not correlate.
    bool refine(cv::Point2f p, cv::Point2f* q) const {
        cv::Matx23d inverse;
        cv::invertAffineTransform(prior, inverse);
        const cv::Point2f start = apply(inverse, *q);
        std::vector<cv::Point2f> from{p}, to{start};
        std::vector<uint8_t> status;
        std::vector<float> error;
        const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
        cv::calcOpticalFlowPyrLK(a8, warped, from, to, status, error,
                                 cv::Size(kRefineWindow, kRefineWindow), 1, stop,
                                 cv::OPTFLOW_USE_INITIAL_FLOW);
        const cv::Point2f drift = to[0] - start;
        if (!status[0] || !inside(to[0], warped.size()) ||
            std::hypot(drift.x, drift.y) >= options->ransac_px) {
            return false;
        }
        const int x = static_cast<int>(std::lround(p.x)), y = static_cast<int>(std::lround(p.y));
        const cv::Point2f u = to[0] - cv::Point2f(static_cast<float>(x), static_cast<float>(y));
        if (zncc(a8, warped, x, y, {cv::Vec2f(u.x, u.y)}) < options->min_similarity) return false;
        *q = apply(prior, to[0]);
        return true;
    }
};

Field dense_field(const cv::Mat& a8, const cv::Mat& b8, const cv::Matx23d& prior,
                  const AutoMatchOptions& options) {
    Field field{.a8 = a8, .texture = texture(a8), .prior = prior, .options = &options};
    if (prior == kIdentity) {
        field.warped = b8;
    } else {
        cv::warpAffine(b8, field.warped, prior, a8.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                       cv::BORDER_REPLICATE);
    }
    // The forward flow is the answer and runs to full resolution: OpenCV has no FINE preset,
    // and MEDIUM refined one pyramid level further halves its error on the tests. The backward
    // flow only checks it, and stops a level short at a third of the cost.
    auto dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
    dis->setFinestScale(options.full_resolution ? 0 : 1);
    dis->calc(a8, field.warped, field.forward);
    dis->setFinestScale(1);
    dis->calc(field.warped, a8, field.backward);
    return field;
}

// Keeps points at least 1 pixel from every kept one: a 1-pixel bucket grid, 3x3 look-up.
class Spacing {
  public:
    Spacing(double width, double height)
        : cols_(static_cast<int>(width) + 1),
          rows_(static_cast<int>(height) + 1),
          head_(static_cast<size_t>(cols_) * rows_, -1) {}

    bool free(Vec2 p) const {
        const auto [cx, cy] = cell(p);
        for (int y = std::max(cy - 1, 0); y <= std::min(cy + 1, rows_ - 1); ++y) {
            for (int x = std::max(cx - 1, 0); x <= std::min(cx + 1, cols_ - 1); ++x) {
                for (int i = head_[static_cast<size_t>(y) * cols_ + x]; i >= 0; i = next_[i]) {
                    if (norm(points_[i] - p) < 1.0) return false;
                }
            }
        }
        return true;
    }

    void add(Vec2 p) {
        const auto [cx, cy] = cell(p);
        int& head = head_[static_cast<size_t>(cy) * cols_ + cx];
        points_.push_back(p);
        next_.push_back(head);
        head = static_cast<int>(points_.size()) - 1;
    }

  private:
    std::pair<int, int> cell(Vec2 p) const {
        return {std::clamp(static_cast<int>(std::floor(p.x)), 0, cols_ - 1),
                std::clamp(static_cast<int>(std::floor(p.y)), 0, rows_ - 1)};
    }

    int cols_, rows_;
    std::vector<int> head_, next_;
    std::vector<Vec2> points_;
};

// Matches in A's pixels and on B's working copy, converted to each image's own pixels, spaced.
struct Collector {
    Spacing in_a, in_b;
    double sx, sy;  // B's working copy to B
    double ax, ay;  // A's working copy to A
    Matches out = {};
    std::vector<uint8_t> is_flow = {};

    void add(cv::Point2f pa, cv::Point2f qb, bool flow) {
        const Vec2 a{ax * (pa.x + kCentre), ay * (pa.y + kCentre)};
        const Vec2 b{sx * (qb.x + kCentre), sy * (qb.y + kCentre)};
        if (!in_a.free(a) || !in_b.free(b)) return;
        in_a.add(a);
        in_b.add(b);
        out.a.push_back(a);
        out.b.push_back(b);
        is_flow.push_back(flow);
    }

    void count(Verdict v) {
        if (v == Verdict::flat) ++out.rejected_texture;
        if (v == Verdict::inconsistent) ++out.rejected_fb;
        if (v == Verdict::dissimilar) ++out.rejected_similarity;
    }

    // Every (n / max)-th match, then the counts of what is left.
    Matches finish(int max_points) {
        const size_t n = out.a.size();
        if (n > static_cast<size_t>(max_points)) {
            for (size_t k = 0; k < static_cast<size_t>(max_points); ++k) {
                const size_t i = k * n / max_points;
                out.a[k] = out.a[i];
                out.b[k] = out.b[i];
                is_flow[k] = is_flow[i];
            }
            out.a.resize(max_points);
            out.b.resize(max_points);
            is_flow.resize(max_points);
        }
        out.from_flow = static_cast<int>(std::count(is_flow.begin(), is_flow.end(), 1));
        out.from_features = static_cast<int>(out.a.size()) - out.from_flow;
        return std::move(out);
    }
};

void collect_flow(const Field& field, int step, Collector& collect) {
    const cv::Size size = field.forward.size();
    for (int y = step / 2; y < size.height; y += step) {
        for (int x = step / 2; x < size.width; x += step) {
            const cv::Point2f p(static_cast<float>(x), static_cast<float>(y));
            cv::Point2f q;
            const Verdict v = field.map(p, &q);
            if (v == Verdict::kept) {
                collect.add(p, q, true);
            } else {
                collect.count(v);
            }
        }
    }
}

// A feature match must agree with the trusted field within ransac_px, and is then kept at the
// field's point (sub-pixel, where keypoints are not); off the field, it must agree with the
// prior and survive refine().
void collect_features(const Field& field, const Candidates& c, Collector& collect) {
    for (size_t i = 0; i < c.a.size(); ++i) {
        cv::Point2f q;
        const bool trusted = field.map(c.a[i], &q) == Verdict::kept;
        const cv::Point2f model = trusted ? q : apply(field.prior, c.a[i]);
        const cv::Point2f d = c.b[i] - model;
        bool kept = std::hypot(d.x, d.y) < field.options->ransac_px;
        if (kept && !trusted) {
            q = c.b[i];
            kept = field.refine(c.a[i], &q);
        }
        if (kept) {
            collect.add(c.a[i], q, false);
        } else {
            ++collect.out.rejected_ransac;
        }
    }
}

}  // namespace

namespace {

Matches match(const Image& a, const Image& b, const AutoMatchOptions& options) {
    check_inputs(a, b, options);
    const auto report = [&](double done, const char* stage) {
        if (options.progress) options.progress(done, stage);
    };
    report(0.0, "grey");
    cv::Mat a8 = grey8(a);
    if (a8.total() > static_cast<size_t>(kMatchPixels)) {
        // Large images are matched on a copy of at most kMatchPixels pixels: flows at full size
        // cost about 220 bytes a pixel (a flat 8192x8192 PNG of 212 KB took 14.6 GiB here).
        const double s = std::sqrt(static_cast<double>(kMatchPixels) / a8.total());
        const cv::Size size(std::max(1, static_cast<int>(a8.cols * s)),
                            std::max(1, static_cast<int>(a8.rows * s)));
        const cv::Mat own = a8;
        cv::resize(own, a8, size, 0, 0, cv::INTER_AREA);
    }
    cv::Mat b8 = grey8(b);
    if (b8.size() != a8.size()) {
        const cv::Mat own = b8;
        cv::resize(own, b8, a8.size(), 0, 0, cv::INTER_AREA);
    }

    Candidates candidates;
    cv::Matx23d prior = kIdentity;
    if (options.features) {
        report(0.05, "features");
        candidates = match_features(a8, b8, options.ratio);
        prior = global_prior(candidates, a8.size(), options.ransac_px);
    }
    report(0.15, "flow");
    const Field field = dense_field(a8, b8, prior, options);

    if (options.flow && prior == kIdentity && a.width == b.width && a.height == b.height &&
        a8.cols == a.width && a8.rows == a.height) {
        auto copy = [](const cv::Mat& f, std::vector<float>& out) {
            const cv::Mat flat = f.isContinuous() ? f : f.clone();
            out.assign(flat.ptr<float>(), flat.ptr<float>() + flat.total() * 2);
        };
        *options.flow = {a.width, a.height, {}, {}};
        copy(field.forward, options.flow->forward);
        copy(field.backward, options.flow->backward);
    }
    report(0.9, "matches");
    Collector collect{Spacing(a.width, a.height),
                      Spacing(b.width, b.height),
                      static_cast<double>(b.width) / a8.cols,
                      static_cast<double>(b.height) / a8.rows,
                      static_cast<double>(a.width) / a8.cols,
                      static_cast<double>(a.height) / a8.rows};
    collect_flow(field, options.grid_step, collect);
    collect_features(field, candidates, collect);
    Matches matches = collect.finish(options.max_points);
    if (matches.a.empty()) {
        throw Error(
            str("auto_match: no correspondences survived (flow samples: ", matches.rejected_texture,
                " on flat ground, ", matches.rejected_fb, " failing the forward-backward check, ",
                matches.rejected_similarity, " unlike their match; ", matches.rejected_ransac,
                " feature matches off the model); are A and B of one scene?"));
    }
    report(1.0, "done");
    return matches;
}

}  // namespace

Matches auto_match(const Image& a, const Image& b, const AutoMatchOptions& options) {
    return with_opencv_errors("automatic matching", [&] { return match(a, b, options); });
}

}  // namespace tesswave::morph
