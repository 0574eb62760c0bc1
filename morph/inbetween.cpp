#include "inbetween.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "auto_match.h"
#include "core/io/opencv_image.h"
#include "core/math/grid_mesh.h"

namespace tesswave::morph {
namespace {

// Frame `image` (planar float) sampled at x + flow(x) for every pixel x, bilinear, edges
// replicated.
Image warp_by(const Image& image, const cv::Mat& flow) {
    cv::Mat map(flow.size(), CV_32FC2);
    for (int y = 0; y < flow.rows; ++y) {
        const auto* f = flow.ptr<cv::Vec2f>(y);
        auto* m = map.ptr<cv::Vec2f>(y);
        for (int x = 0; x < flow.cols; ++x) m[x] = {x + f[x][0], y + f[x][1]};
    }
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

// Where the mesh's two warps disagree (its motion is wrong there: small fast objects that got
// no correspondences, occlusions), the frame from dense flow competes with it: each weighs
// 1 / (e^2 + floor^2) by its own two warps' disagreement e, the flow's counted 1.5 times, so
// that it wins only where clearly better; and only as far as the flow's frame shows what one of
// the mesh's warps shows (where both warps agree on an object that the flow lost, the flow's two
// warps agree too, on the empty ground). (Bilateral block matching as a third candidate, 8x8
// blocks within +-1/12 of the frame, lost 0.4 dB on average over eval-interp's 16 sequences:
// it picks wrong motions on flat ground and leaves block edges.)
Image with_flow_fallback(const Image& f0, const Image& f1, double t, const Image& mesh,
                         const Image& mesh0, const Image& mesh1) {
    return with_opencv_errors("inbetween", [&] {
        const cv::Mat a = grey8(f0), b = grey8(f1);
        cv::Mat f01, f10;
        auto dis = cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
        dis->calc(a, b, f01);
        dis->calc(b, a, f10);
        // The flows from the moment t back to each frame, from the two flows at the frames
        // (motion straight and steady over the pair, flows read at the same pixel).
        cv::Mat to0 = -(1 - t) * t * f01 + t * t * f10;
        cv::Mat to1 = (1 - t) * (1 - t) * f01 - t * (1 - t) * f10;
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
    });
}

}  // namespace

PairMeshes automatic_pair(const Image& f0, const Image& f1, double cell) {
    const Matches m = auto_match(f0, f1);
    const int cols = std::max(1, static_cast<int>(std::lround(f0.width / cell)));
    const int rows = std::max(1, static_cast<int>(std::lround(f0.height / cell)));
    return fitted_pair(grid_mesh(f0.width, f0.height, cols, rows), {m.a, m.b}, f1.width, f1.height);
}

Image inbetween(const Image& f0, const Image& f1, double t, const InbetweenOptions& options) {
    const PairMeshes pair = automatic_pair(f0, f1, options.cell);
    const Morph morph(f0, f1, pair.a, pair.b, options.morph);
    Image frame = morph.frame(t);
    if (!options.flow_fallback || f0.width != f1.width || f0.height != f1.height ||
        f0.channels() != f1.channels()) {
        return frame;
    }
    return with_flow_fallback(f0, f1, t, frame, morph.warped(t, 0), morph.warped(t, 1));
}

}  // namespace tesswave::morph
