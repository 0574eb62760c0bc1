#include "peer_morph.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/io/opencv_image.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

cv::Mat as_mat(const Image& image) {
    std::vector<cv::Mat> planes;
    for (const auto& p : image.planes) {
        planes.emplace_back(image.height, image.width, CV_32F, const_cast<float*>(p.data()));
    }
    cv::Mat out;
    cv::merge(planes, out);
    return out;
}

Image from_mat(const cv::Mat& m, SampleFormat format) {
    Image out = make_image(m.cols, m.rows, m.channels(), format);
    std::vector<cv::Mat> planes;
    cv::split(m, planes);
    for (int c = 0; c < m.channels(); ++c) {
        for (int y = 0; y < m.rows; ++y) {
            std::copy_n(planes[c].ptr<float>(y), m.cols, out.planes[c].data() + size_t(y) * m.cols);
        }
    }
    return out;
}

// RGB of any image (grey widened, alpha dropped), as the morph itself does.
Image rgb(const Image& image) {
    Image out = make_image(image.width, image.height, 3, image.format);
    for (int c = 0; c < 3; ++c) out.planes[c] = image.planes[std::min(c, image.channels() - 1)];
    if (image.channels() < 3) out.planes[1] = out.planes[2] = image.planes[0];
    return out;
}

}  // namespace

ClassicMorph::ClassicMorph(const Image& a, const Image& b, const Mesh& mesh_a, const Mesh& mesh_b)
    : a_(rgb(a)), b_(rgb(b)), va_(mesh_a.vertices), vb_(mesh_b.vertices) {
    if (mesh_a.face_offsets != mesh_b.face_offsets || mesh_a.face_corners != mesh_b.face_corners ||
        mesh_a.num_vertices() != mesh_b.num_vertices()) {
        throw Error("classic morph: the two meshes do not share one topology");
    }
    sx_ = static_cast<double>(a.width) / b.width;
    sy_ = static_cast<double>(a.height) / b.height;
    for (int f = 0; f < mesh_a.num_faces(); ++f) {
        const auto face = mesh_a.face(f);
        for (size_t k = 2; k < face.size(); ++k)
            triangles_.push_back({face[0], face[k - 1], face[k]});
    }
}

void ClassicMorph::maps(double t, std::vector<float>& xa, std::vector<float>& ya,
                        std::vector<float>& xb, std::vector<float>& yb) const {
    const int W = a_.width, H = a_.height;
    for (auto* m : {&xa, &ya, &xb, &yb}) m->assign(size_t(W) * H, -1.0f);
    for (const auto& tri : triangles_) {
        Vec2 p[3], pa[3], pb[3];
        for (int k = 0; k < 3; ++k) {
            pa[k] = va_[tri[k]];
            pb[k] = vb_[tri[k]];
            p[k] = (1 - t) * pa[k] + t * Vec2{pb[k].x * sx_, pb[k].y * sy_};
        }
        const double area = cross(p[1] - p[0], p[2] - p[0]);
        if (area == 0) continue;
        const int x0 =
            std::max(0, static_cast<int>(std::floor(std::min({p[0].x, p[1].x, p[2].x}))));
        const int x1 =
            std::min(W - 1, static_cast<int>(std::ceil(std::max({p[0].x, p[1].x, p[2].x}))));
        const int y0 =
            std::max(0, static_cast<int>(std::floor(std::min({p[0].y, p[1].y, p[2].y}))));
        const int y1 =
            std::min(H - 1, static_cast<int>(std::ceil(std::max({p[0].y, p[1].y, p[2].y}))));
        for (int y = y0; y <= y1; ++y) {
            for (int x = x0; x <= x1; ++x) {
                const Vec2 q{x + 0.5, y + 0.5};
                const double l1 = cross(p[2] - p[1], q - p[1]) / area;
                const double l2 = cross(p[0] - p[2], q - p[2]) / area;
                const double l3 = 1 - l1 - l2;
                if (l1 < -1e-9 || l2 < -1e-9 || l3 < -1e-9) continue;
                const Vec2 qa = l1 * pa[0] + l2 * pa[1] + l3 * pa[2];
                const Vec2 qb = l1 * pb[0] + l2 * pb[1] + l3 * pb[2];
                const size_t i = size_t(y) * W + x;
                // cv::remap puts pixel i's centre at i; ours is at i + 1/2.
                xa[i] = static_cast<float>(qa.x - 0.5);
                ya[i] = static_cast<float>(qa.y - 0.5);
                xb[i] = static_cast<float>(qb.x - 0.5);
                yb[i] = static_cast<float>(qb.y - 0.5);
            }
        }
    }
}

Image ClassicMorph::warped(double t, int side) const {
    return with_opencv_errors("classic morph", [&] {
        std::vector<float> xa, ya, xb, yb;
        maps(t, xa, ya, xb, yb);
        const int W = a_.width, H = a_.height;
        cv::Mat mx(H, W, CV_32F, side ? xb.data() : xa.data());
        cv::Mat my(H, W, CV_32F, side ? yb.data() : ya.data());
        cv::Mat out;
        cv::remap(as_mat(side ? b_ : a_), out, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
        return from_mat(out, a_.format);
    });
}

Image ClassicMorph::frame(double t) const {
    return with_opencv_errors("classic morph", [&] {
        std::vector<float> xa, ya, xb, yb;
        maps(t, xa, ya, xb, yb);
        const int W = a_.width, H = a_.height;
        cv::Mat wa, wb, out;
        cv::remap(as_mat(a_), wa, cv::Mat(H, W, CV_32F, xa.data()),
                  cv::Mat(H, W, CV_32F, ya.data()), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
        cv::remap(as_mat(b_), wb, cv::Mat(H, W, CV_32F, xb.data()),
                  cv::Mat(H, W, CV_32F, yb.data()), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
        cv::addWeighted(wa, 1 - t, wb, t, 0, out);
        return from_mat(out, a_.format);
    });
}

MorphMeasures measure_middle(const Image& middle, const Image& warped_a, const Image& warped_b) {
    if (middle.width != warped_a.width || middle.height != warped_a.height ||
        middle.width != warped_b.width || middle.height != warped_b.height) {
        throw Error(str("morph measures: the frames differ in size (", middle.width, "x",
                        middle.height, ", ", warped_a.width, "x", warped_a.height, ", ",
                        warped_b.width, "x", warped_b.height, ")"));
    }
    return with_opencv_errors("morph measures", [&] {
        const int W = middle.width, H = middle.height;
        // Per pixel, summed over the three channels: the products the measures need.
        enum { mm, aa, bb, ab, ma, mb, count };
        std::vector<cv::Mat> s(count);
        for (cv::Mat& m : s) m = cv::Mat::zeros(H, W, CV_32F);
        const Image* images[3] = {&middle, &warped_a, &warped_b};
        for (int c = 0; c < 3; ++c) {
            cv::Mat d[3];
            for (int k = 0; k < 3; ++k) {
                const Image& im = *images[k];
                const auto& plane = im.planes[std::min(c, im.channels() - 1)];
                cv::Mat m(H, W, CV_32F, const_cast<float*>(plane.data())), blur;
                cv::blur(m, blur, {5, 5}, {-1, -1}, cv::BORDER_REFLECT);
                d[k] = m - blur;
            }
            s[mm] += d[0].mul(d[0]);
            s[aa] += d[1].mul(d[1]);
            s[bb] += d[2].mul(d[2]);
            s[ab] += d[1].mul(d[2]);
            s[ma] += d[0].mul(d[1]);
            s[mb] += d[0].mul(d[2]);
        }
        std::vector<cv::Mat> w(count);
        for (int k = 0; k < count; ++k) cv::blur(s[k], w[k], {9, 9}, {-1, -1}, cv::BORDER_REFLECT);
        double total_m = 0, total_ends = 0, kept_m = 0, kept_ends = 0, ghost = 0;
        for (int y = 0; y < H; ++y) {
            for (int x = 0; x < W; ++x) {
                auto at = [&](int k) { return double{w[k].at<float>(y, x)}; };
                const double e_a = at(aa), e_b = at(bb), ends = 0.5 * (e_a + e_b);
                const double c =
                    e_a > 0 && e_b > 0 ? std::clamp(at(ab) / std::sqrt(e_a * e_b), 0.0, 1.0) : 0;
                total_m += at(mm);
                total_ends += ends;
                if (c >= 0.5) {
                    kept_m += at(mm);
                    kept_ends += ends;
                }
                const double from_a = e_a > 0 ? at(ma) * at(ma) / e_a : 0;
                const double from_b = e_b > 0 ? at(mb) * at(mb) / e_b : 0;
                ghost += (1 - c) * (from_a + from_b);
            }
        }
        MorphMeasures m;
        m.detail = total_ends > 0 ? total_m / total_ends : 0;
        m.kept = kept_ends > 0 ? kept_m / kept_ends : 0;
        m.ghost = total_ends > 0 ? ghost / total_ends : 0;
        return m;
    });
}

}  // namespace tesswave
