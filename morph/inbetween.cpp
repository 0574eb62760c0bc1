#include "inbetween.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "auto_match.h"
#include "core/io/opencv_image.h"
#include "core/math/grid_mesh.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"

namespace tesswave::morph {
namespace {

// The positions x + flow(x) of every pixel x, as cv::remap takes them.
cv::Mat positions(const cv::Mat& flow) {
    cv::Mat map(flow.size(), CV_32FC2);
    for (int y = 0; y < flow.rows; ++y) {
        const auto* f = flow.ptr<cv::Vec2f>(y);
        auto* m = map.ptr<cv::Vec2f>(y);
        for (int x = 0; x < flow.cols; ++x) m[x] = {x + f[x][0], y + f[x][1]};
    }
    return map;
}

// Frame `image` (planar float) sampled at x + flow(x) for every pixel x, bilinear, edges
// replicated.
Image warp_by(const Image& image, const cv::Mat& flow) {
    const cv::Mat map = positions(flow);
    Image out = make_image(image.width, image.height, image.channels(), image.format);
    for (int c = 0; c < image.channels(); ++c) {
        const cv::Mat plane(image.height, image.width, CV_32F,
                            const_cast<float*>(image.planes[c].data()));
        cv::Mat dst(image.height, image.width, CV_32F, out.planes[c].data());
        cv::remap(plane, dst, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    }
    return out;
}

// How badly two warps of the same moment disagree around each pixel: the squared difference
// over channels, smoothed over about 7 pixels.
cv::Mat disagreement(const Image& p, const Image& q) {
    cv::Mat e = cv::Mat::zeros(p.height, p.width, CV_32F);
    for (int c = 0; c < p.channels() && c < q.channels(); ++c) {
        for (size_t i = 0; i < p.planes[c].size(); ++i) {
            const float d = p.planes[c][i] - q.planes[c][i];
            e.ptr<float>()[i] += d * d;
        }
    }
    cv::GaussianBlur(e, e, {0, 0}, 2.5);
    return e;
}

// The dense flows between the two frames, both ways (DIS), on 8-bit grey: auto_match's when it
// kept them (`given`, which must outlive the result), else computed here. automatic_pair asks
// auto_match for flows that stop a pyramid level short of full resolution, as these do: over
// eval-interp's 16 triplets that was 0.02 dB better on average (each within 0.11 dB but UCF101 7,
// +0.55) and 12 % faster than a full-resolution forward flow for matching and a second one here.
struct Flows {
    cv::Mat a, b;      // the frames' grey
    cv::Mat f01, f10;  // CV_32FC2, per pixel of f0 (f1): where it is in f1 (f0), relative
};

Flows dense_flows(const Image& f0, const Image& f1, DenseFlow& given) {
    Flows f{grey8(f0), grey8(f1), {}, {}};
    if (given.width == f0.width && given.height == f0.height) {
        f.f01 = cv::Mat(f0.height, f0.width, CV_32FC2, given.forward.data());
        f.f10 = cv::Mat(f0.height, f0.width, CV_32FC2, given.backward.data());
        return f;
    }
    auto dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
    dis->calc(f.a, f.b, f.f01);
    dis->calc(f.b, f.a, f.f10);
    return f;
}

// Where the mesh's two warps disagree (its motion is wrong there: small fast objects that got
// no correspondences, occlusions), the frame from dense flow competes with it: each weighs
// 1 / (e^2 + floor^2) by its own two warps' disagreement e, the flow's counted 1.5 times, so
// that it wins only where clearly better; and only as far as the flow's frame shows what one of
// the mesh's warps shows (where both warps agree on an object the flow lost, the flow's two
// warps agree too, on the empty ground). `to0` and `to1` receive the flow's motion from the
// moment t back to each frame.
Image with_flow_fallback(const Image& f0, const Image& f1, double t, const Flows& flows,
                         const Image& mesh, const Image& mesh0, const Image& mesh1, cv::Mat& to0,
                         cv::Mat& to1) {
    // The flows from the moment t back to each frame, from the two flows at the frames (motion
    // straight and steady over the pair, flows read at the same pixel).
    to0 = -(1 - t) * t * flows.f01 + t * t * flows.f10;
    to1 = (1 - t) * (1 - t) * flows.f01 - t * (1 - t) * flows.f10;
    const Image flow0 = warp_by(f0, to0), flow1 = warp_by(f1, to1);
    const cv::Mat e_mesh = disagreement(mesh0, mesh1), e_flow = disagreement(flow0, flow1);
    // How far the flow's frame is from the nearer of the mesh's two warps: where it shows
    // neither (the mesh's warps agree on an object the flow lost), it may not take over.
    Image flow = flow0;
    for (int c = 0; c < flow.channels(); ++c) {
        for (size_t i = 0; i < flow.planes[c].size(); ++i) {
            flow.planes[c][i] = (1 - t) * flow0.planes[c][i] + t * flow1.planes[c][i];
        }
    }
    const cv::Mat to_mesh0 = disagreement(flow, mesh0), to_mesh1 = disagreement(flow, mesh1);
    const cv::Mat apart = cv::min(to_mesh0, to_mesh1);
    const float floor = 1e-5f;  // a tie: 0.3 % of full scale over the channels
    Image out = mesh;
    for (size_t i = 0; i < out.planes[0].size(); ++i) {
        const float em = e_mesh.ptr<float>()[i], ef = 1.5f * e_flow.ptr<float>()[i];
        const float d = apart.ptr<float>()[i];
        const float w = em * em / (em * em + ef * ef + floor * floor) * em / (em + d + floor);
        if (w < 1e-3f) continue;
        for (int c = 0; c < out.channels(); ++c) {
            out.planes[c][i] += w * (flow.planes[c][i] - out.planes[c][i]);
        }
    }
    return out;
}

// Motion the dense flow misses: a small object moving fast (a thrown ball) vanishes from the
// flow's coarse levels, so the flow gives it the ground's motion. Where frame a, fetched from b
// through the flow, still differs (8x8 blocks of mean error over kMinError grey levels), a full
// search in b within `radius` of the block with a 4-pixel margin finds its displacement, kept
// when it matches at most a third as badly as the flow; each pixel of the block takes it where
// it matches better than the flow there. (Bilateral block matching everywhere, 8x8 blocks within
// +-1/12 of the frame, as a third candidate beside the mesh and the flow, lost 0.4 dB on average
// over eval-interp's 16 sequences: it picks wrong motions on flat ground and leaves block
// edges. Searching only where the flow failed, and keeping only what both directions confirm,
// avoids both.)
struct FastMotion {
    cv::Mat d;       // CV_32FC2: a pixel's displacement a -> b, where `moved`
    cv::Mat moved;   // CV_8U: 255 where block matching beat the flow
    cv::Mat failed;  // CV_8U: 255 where the flow's local error is over kMinError
};

FastMotion fast_motion(const cv::Mat& a8, const cv::Mat& b8, const cv::Mat& flow, int radius) {
    constexpr int kBlock = 8;
    constexpr double kMinError = 12, kMargin = 2;
    cv::Mat a, b;
    a8.convertTo(a, CV_32F);
    b8.convertTo(b, CV_32F);
    cv::Mat fetched, err, err_local;
    cv::remap(b, fetched, positions(flow), cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    err = cv::abs(a - fetched);
    cv::blur(err, err_local, {3, 3});
    FastMotion out{cv::Mat::zeros(a.size(), CV_32FC2), cv::Mat::zeros(a.size(), CV_8U), {}};
    out.failed = err_local >= kMinError;
    const cv::Rect frame(0, 0, b.cols, b.rows);
    // The blocks the flow failed on, worst first. More than a quarter of them is no small
    // object (a cut, a change of view): nothing is searched. At most one block in 16 is.
    std::vector<std::pair<double, cv::Point>> failed;
    int blocks = 0;
    for (int by = 0; by + kBlock <= a.rows; by += kBlock) {
        for (int bx = 0; bx + kBlock <= a.cols; bx += kBlock, ++blocks) {
            const double e = cv::mean(err(cv::Rect(bx, by, kBlock, kBlock)))[0];
            if (e >= kMinError) failed.push_back({e, {bx, by}});
        }
    }
    if (failed.size() > static_cast<size_t>(blocks / 4)) return out;
    const size_t searched = std::min(failed.size(), static_cast<size_t>(std::max(1, blocks / 16)));
    std::partial_sort(failed.begin(), failed.begin() + searched, failed.end(),
                      [](const auto& p, const auto& q) { return p.first > q.first; });
    for (size_t k = 0; k < searched; ++k) {
        const int bx = failed[k].second.x, by = failed[k].second.y;
        const cv::Rect block(bx, by, kBlock, kBlock);
        // The block with a margin of kBlock / 2: the edges of an object give its texture.
        const cv::Rect tmpl =
            cv::Rect(bx - kBlock / 2, by - kBlock / 2, 2 * kBlock, 2 * kBlock) & frame;
        const cv::Rect window = cv::Rect(tmpl.x - radius, tmpl.y - radius, tmpl.width + 2 * radius,
                                         tmpl.height + 2 * radius) &
                                frame;
        cv::Mat cost;
        cv::matchTemplate(b(window), a(tmpl), cost, cv::TM_SQDIFF);
        double best = 0;
        cv::Point at;
        cv::minMaxLoc(cost, &best, nullptr, &at);
        if (best > cv::norm(err(tmpl), cv::NORM_L2SQR) / 3) continue;
        const cv::Point d(window.x + at.x - tmpl.x, window.y + at.y - tmpl.y);
        if (!frame.contains({bx + d.x, by + d.y}) ||
            !frame.contains({bx + d.x + kBlock - 1, by + d.y + kBlock - 1})) {
            continue;
        }
        cv::Mat e = cv::abs(a(block) - b(block + d));
        cv::blur(e, e, {3, 3}, {-1, -1}, cv::BORDER_REPLICATE);
        for (int y = 0; y < kBlock; ++y) {
            for (int x = 0; x < kBlock; ++x) {
                if (e.at<float>(y, x) + kMargin >= err_local.at<float>(by + y, bx + x)) continue;
                out.d.at<cv::Vec2f>(by + y, bx + x) = {float(d.x), float(d.y)};
                out.moved.at<uint8_t>(by + y, bx + x) = 255;
            }
        }
    }
    return out;
}

// Keeps the moved pixels of `m` whose displacement the other direction confirms: the pixel it
// lands on in the other frame moved too, back to within 2.5 px of where it came from.
FastMotion confirmed(const FastMotion& m, const FastMotion& back) {
    FastMotion out{m.d.clone(), cv::Mat::zeros(m.moved.size(), CV_8U), m.failed};
    for (int y = 0; y < m.moved.rows; ++y) {
        for (int x = 0; x < m.moved.cols; ++x) {
            if (!m.moved.at<uint8_t>(y, x)) continue;
            const cv::Vec2f d = m.d.at<cv::Vec2f>(y, x);
            const int tx = x + static_cast<int>(d[0]), ty = y + static_cast<int>(d[1]);
            if (tx < 0 || ty < 0 || tx >= m.moved.cols || ty >= m.moved.rows ||
                !back.moved.at<uint8_t>(ty, tx)) {
                continue;
            }
            if (cv::norm(d + back.d.at<cv::Vec2f>(ty, tx)) <= 2.5)
                out.moved.at<uint8_t>(y, x) = 255;
        }
    }
    return out;
}

// One displacement for each connected group of moved pixels, the median of its pixels' (an
// object moves as a whole; a spinning one matches block by block with scattered displacements).
FastMotion unified(FastMotion m) {
    cv::Mat labels;
    const int count = cv::connectedComponents(m.moved, labels, 8, CV_32S);
    std::vector<std::vector<float>> xs(count), ys(count);
    for (int y = 0; y < labels.rows; ++y) {
        for (int x = 0; x < labels.cols; ++x) {
            const int l = labels.at<int32_t>(y, x);
            if (l == 0) continue;
            xs[l].push_back(m.d.at<cv::Vec2f>(y, x)[0]);
            ys[l].push_back(m.d.at<cv::Vec2f>(y, x)[1]);
        }
    }
    std::vector<cv::Vec2f> median(count);
    for (int l = 1; l < count; ++l) {
        auto mid = [](std::vector<float>& v) {
            std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
            return v[v.size() / 2];
        };
        median[l] = {mid(xs[l]), mid(ys[l])};
    }
    for (int y = 0; y < labels.rows; ++y) {
        for (int x = 0; x < labels.cols; ++x) {
            const int l = labels.at<int32_t>(y, x);
            if (l != 0) m.d.at<cv::Vec2f>(y, x) = median[l];
        }
    }
    return m;
}

// Grows each object into the pixels around it where the flow failed too (parts whose look
// changed, a spinning ball's far side), `steps` pixels at most, with its displacement.
FastMotion grown(FastMotion m, int steps) {
    for (int step = 0; step < steps; ++step) {
        FastMotion out{m.d.clone(), m.moved.clone(), m.failed};
        for (int y = 0; y < m.moved.rows; ++y) {
            for (int x = 0; x < m.moved.cols; ++x) {
                if (m.moved.at<uint8_t>(y, x) || !m.failed.at<uint8_t>(y, x)) continue;
                for (int k = 0; k < 9; ++k) {
                    const int yy = y + k / 3 - 1, xx = x + k % 3 - 1;
                    if (yy < 0 || xx < 0 || yy >= m.moved.rows || xx >= m.moved.cols ||
                        !m.moved.at<uint8_t>(yy, xx)) {
                        continue;
                    }
                    out.d.at<cv::Vec2f>(y, x) = m.d.at<cv::Vec2f>(yy, xx);
                    out.moved.at<uint8_t>(y, x) = 255;
                    break;
                }
            }
        }
        m = std::move(out);
    }
    return m;
}

// Fills the gaps of the moved pixels (soft edges, flat insides that matched no better than the
// flow): a pixel with at least 10 moved pixels among its 5x5 neighbours takes their mean
// displacement. Twice.
FastMotion filled(FastMotion m) {
    for (int pass = 0; pass < 2; ++pass) {
        FastMotion out{m.d.clone(), m.moved.clone(), m.failed};
        for (int y = 0; y < m.moved.rows; ++y) {
            for (int x = 0; x < m.moved.cols; ++x) {
                if (m.moved.at<uint8_t>(y, x)) continue;
                int count = 0;
                cv::Vec2f sum(0, 0);
                for (int yy = std::max(0, y - 2); yy <= std::min(m.moved.rows - 1, y + 2); ++yy) {
                    for (int xx = std::max(0, x - 2); xx <= std::min(m.moved.cols - 1, x + 2);
                         ++xx) {
                        if (!m.moved.at<uint8_t>(yy, xx)) continue;
                        ++count;
                        sum += m.d.at<cv::Vec2f>(yy, xx);
                    }
                }
                if (count < 10) continue;
                out.d.at<cv::Vec2f>(y, x) = sum / count;
                out.moved.at<uint8_t>(y, x) = 255;
            }
        }
        m = std::move(out);
    }
    return m;
}

// The objects that fast_motion found, moved to the moment t: each moved pixel of f0 (f1) is
// carried along its displacement to t, and there the frame takes both frames' views of it.
// Where such an object was in f0 (f1) and is no longer at t, the frame shows what f1 (f0) shows
// there, fetched through the flow's motion to it (`to1`, `to0`).
Image with_fast_objects(const Image& f0, const Image& f1, double t, Image frame,
                        const FastMotion& m01, const FastMotion& m10, const cv::Mat& to0,
                        const cv::Mat& to1) {
    const int W = frame.width, H = frame.height;
    cv::Mat motion = cv::Mat::zeros(H, W, CV_32FC2);  // at t: the object's motion f0 -> f1
    cv::Mat covered = cv::Mat::zeros(H, W, CV_8U);
    auto carry = [&](const FastMotion& m, float along, float sign) {
        for (int y = 0; y < H; ++y) {
            for (int x = 0; x < W; ++x) {
                if (!m.moved.at<uint8_t>(y, x)) continue;
                const cv::Vec2f d = m.d.at<cv::Vec2f>(y, x);
                const float qx = x + along * d[0], qy = y + along * d[1];
                for (int yy = static_cast<int>(std::floor(qy)); yy <= std::ceil(qy); ++yy) {
                    for (int xx = static_cast<int>(std::floor(qx)); xx <= std::ceil(qx); ++xx) {
                        if (xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
                        motion.at<cv::Vec2f>(yy, xx) = sign * d;
                        covered.at<uint8_t>(yy, xx) = 255;
                    }
                }
            }
        }
    };
    carry(m01, static_cast<float>(t), 1.0f);
    carry(m10, static_cast<float>(1 - t), -1.0f);
    // The pixels that change and where each reads f0 and f1 (pixel centres at +1/2): covered
    // ones read both, vacated ones the frame that shows the ground there.
    const double s = t;
    std::vector<size_t> both, only0, only1;
    std::vector<Vec2> both0, both1, at0, at1;
    for (int y = 0; y < H; ++y) {
        for (int x = 0; x < W; ++x) {
            const size_t i = static_cast<size_t>(y) * W + x;
            const Vec2 centre{x + 0.5, y + 0.5};
            if (covered.at<uint8_t>(y, x)) {
                const cv::Vec2f d = motion.at<cv::Vec2f>(y, x);
                both.push_back(i);
                both0.push_back(centre - s * Vec2{d[0], d[1]});
                both1.push_back(centre + (1 - s) * Vec2{d[0], d[1]});
            } else if (m01.moved.at<uint8_t>(y, x) && !m10.moved.at<uint8_t>(y, x)) {
                const cv::Vec2f d = to1.at<cv::Vec2f>(y, x);
                only1.push_back(i);
                at1.push_back(centre + Vec2{d[0], d[1]});
            } else if (m10.moved.at<uint8_t>(y, x) && !m01.moved.at<uint8_t>(y, x)) {
                const cv::Vec2f d = to0.at<cv::Vec2f>(y, x);
                only0.push_back(i);
                at0.push_back(centre + Vec2{d[0], d[1]});
            }
        }
    }
    const auto v0 = sample_bilinear(f0, both0), v1 = sample_bilinear(f1, both1);
    const auto g0 = sample_bilinear(f0, at0), g1 = sample_bilinear(f1, at1);
    for (int c = 0; c < frame.channels(); ++c) {
        auto& out = frame.planes[c];
        for (size_t k = 0; k < both.size(); ++k) {
            out[both[k]] = static_cast<float>((1 - s) * v0[c][k] + s * v1[c][k]);
        }
        for (size_t k = 0; k < only0.size(); ++k) out[only0[k]] = g0[c][k];
        for (size_t k = 0; k < only1.size(); ++k) out[only1[k]] = g1[c][k];
    }
    return frame;
}

// A grid of about `cell`-pixel cells over the frame.
Mesh cell_grid(const Image& frame, double cell) {
    const int cols = std::max(1, static_cast<int>(std::lround(frame.width / cell)));
    const int rows = std::max(1, static_cast<int>(std::lround(frame.height / cell)));
    return grid_mesh(frame.width, frame.height, cols, rows);
}

}  // namespace

PairMeshes automatic_pair(const Image& f0, const Image& f1, double cell, DenseFlow* flow) {
    const Matches m = auto_match(f0, f1, {.flow = flow, .full_resolution = false});
    return fitted_pair(cell_grid(f0, cell), {m.a, m.b}, f1.width, f1.height);
}

PairMeshes automatic_pair_or_rest(const Image& f0, const Image& f1, double cell, std::string* note,
                                  DenseFlow* flow) {
    if (f0.width != f1.width || f0.height != f1.height) return automatic_pair(f0, f1, cell, flow);
    try {
        return automatic_pair(f0, f1, cell, flow);
    } catch (const Error& e) {
        if (note) *note = str(e.what(), "; the mesh stays at rest");
        return rest_pair(cell_grid(f0, cell), f1.width, f1.height);
    }
}

Image inbetween(const Image& f0, const Image& f1, double t, const InbetweenOptions& options,
                std::string* note) {
    // Frames under 16 pixels a side are auto_match's to refuse (DIS needs 12).
    const bool flow = options.flow_fallback && f0.width == f1.width && f0.height == f1.height &&
                      f0.channels() == f1.channels() && std::min(f0.width, f0.height) >= 16;
    // At rest, the flow and the fast objects can still make the frame.
    DenseFlow kept;
    const PairMeshes pair = flow ? automatic_pair_or_rest(f0, f1, options.cell, note, &kept)
                                 : automatic_pair(f0, f1, options.cell);
    const Morph morph(f0, f1, pair.a, pair.b, options.morph);
    Image frame = morph.frame(t);
    if (!flow) return frame;
    return with_opencv_errors("inbetween", [&] {
        const Flows flows = dense_flows(f0, f1, kept);
        cv::Mat to0, to1;
        Image out = with_flow_fallback(f0, f1, t, flows, frame, morph.warped(t, 0),
                                       morph.warped(t, 1), to0, to1);
        if (!options.fast_objects) return out;
        const int radius = std::clamp(std::max(f0.width, f0.height) / 5, 16, 64);
        const FastMotion m01 = fast_motion(flows.a, flows.b, flows.f01, radius);
        const FastMotion m10 = fast_motion(flows.b, flows.a, flows.f10, radius);
        // Objects grow by at most a block into their unmatched parts.
        auto objects = [](const FastMotion& m, const FastMotion& back) {
            return grown(unified(filled(confirmed(m, back))), 8);
        };
        return with_fast_objects(f0, f1, t, std::move(out), objects(m01, m10), objects(m10, m01),
                                 to0, to1);
    });
}

}  // namespace tesswave::morph
