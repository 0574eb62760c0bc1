#include "warp.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/math/error.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"

namespace tesswave::morph {

namespace {

void check_same_size(const Image& a, const Image& b, const char* what) {
    if (a.width != b.width || a.height != b.height || a.channels() != b.channels()) {
        throw Error(str(what, ": the images differ (", a.width, "x", a.height, "x", a.channels(),
                        " and ", b.width, "x", b.height, "x", b.channels(), ")"));
    }
}

}  // namespace

Image detail_agreement(const Image& a, const Image& b) {
    check_same_size(a, b, "detail agreement");
    const int W = a.width, H = a.height;
    cv::Mat sums[3];  // aa, bb, ab
    for (cv::Mat& m : sums) m = cv::Mat::zeros(H, W, CV_32F);
    for (int c = 0; c < std::min(a.channels(), 3); ++c) {
        cv::Mat detail[2];
        for (int k = 0; k < 2; ++k) {
            const Image& im = k == 0 ? a : b;
            const cv::Mat m(H, W, CV_32F, const_cast<float*>(im.planes[c].data()));
            cv::Mat mean;
            cv::blur(m, mean, {5, 5}, {-1, -1}, cv::BORDER_REFLECT);
            detail[k] = m - mean;
        }
        sums[0] += detail[0].mul(detail[0]);
        sums[1] += detail[1].mul(detail[1]);
        sums[2] += detail[0].mul(detail[1]);
    }
    for (cv::Mat& m : sums) cv::blur(m, m, {9, 9}, {-1, -1}, cv::BORDER_REFLECT);
    Image out = make_image(W, H, 1, SampleFormat::f32);
    const float *aa = sums[0].ptr<float>(), *bb = sums[1].ptr<float>(), *ab = sums[2].ptr<float>();
    for (size_t i = 0; i < out.planes[0].size(); ++i) {
        const double e = double{aa[i]} * bb[i];
        out.planes[0][i] =
            e > 0 ? static_cast<float>(std::clamp(ab[i] / std::sqrt(e), 0.0, 1.0)) : 0;
    }
    return out;
}

std::vector<std::vector<float>> residual_energies(const Image& ra, const Image& rb) {
    check_same_size(ra, rb, "residual energies");
    const int W = ra.width, H = ra.height;
    std::vector<std::vector<float>> out;
    for (int k = 0; k < 3; ++k) {
        std::vector<float> sums(static_cast<size_t>(W) * H, 0.0f);
        for (int c = 0; c < ra.channels(); ++c) {
            const float* x = (k == 1 ? rb : ra).planes[c].data();
            const float* y = (k == 0 ? ra : rb).planes[c].data();
            for (size_t i = 0; i < sums.size(); ++i) sums[i] += x[i] * y[i];
        }
        cv::Mat m(H, W, CV_32F, sums.data());
        cv::boxFilter(m, m, -1, {7, 7});
        out.push_back(std::move(sums));
    }
    return out;
}

Image warped_through(const RenderPlan& plan, std::span<const QuadMap> quads, const Image& b) {
    Image out = make_image(plan.width, plan.height, b.channels(), SampleFormat::f32);
    render_each<0>(plan, {}, [&](int32_t px, const float*, PlanPlace at) {
        const Tap tap = bilinear_tap(b.width, b.height, 1.0, quads[at.quad].at(at.u, at.v));
        for (int c = 0; c < b.channels(); ++c)
            out.planes[c][px] = bilinear_at(tap, b.planes[c].data());
    });
    return out;
}

std::vector<QuadMap> quad_maps(const std::vector<Quad>& quads) {
    std::vector<QuadMap> out;
    out.reserve(quads.size());
    for (const Quad& q : quads) {  // p00, p10, p11, p01
        const Vec2 a = q[1] - q[0], b = q[3] - q[0], c = (q[2] - q[1]) - b;
        const auto f = [](double x) { return static_cast<float>(x); };
        out.push_back({f(q[0].x), f(q[0].y), f(a.x), f(a.y), f(b.x), f(b.y), f(c.x), f(c.y)});
    }
    return out;
}

}  // namespace tesswave::morph
