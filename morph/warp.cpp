#include "warp.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#if defined(__x86_64__)
#include "core/math/bilinear4.h"
#endif

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

namespace {

#if defined(__x86_64__)
#define TESSWAVE_AVX2 [[gnu::target("avx2"), gnu::always_inline]] inline

// bilinear_tap(w, h, 1, m.at(u, v)) for four pixels, in floats: m.at's sums as it adds them, and
// the tap's clamps and fractions as bilinear_tap computes them in doubles. Those are exact in
// floats for the positions of images below 2^22 pixels a side (p - 1/2 is exact from p = 1/4 on,
// and below 1/4 it is negative either way, hence 0; f - x0 is exact as f < 2 x0 or x0 = 0), so
// the same bits. The image is at least 2x2 pixels (detail::Taps4).
TESSWAVE_AVX2 __m128 axis4(float o, float a, float b, float c, __m128 u, __m128 v) {
    return _mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_set1_ps(o), _mm_mul_ps(u, _mm_set1_ps(a))),
                                 _mm_mul_ps(v, _mm_set1_ps(b))),
                      _mm_mul_ps(_mm_mul_ps(u, v), _mm_set1_ps(c)));
}
TESSWAVE_AVX2 detail::Taps4 taps4(const QuadMap& m, __m128 u, __m128 v, int w, int h) {
    const __m128 half = _mm_set1_ps(0.5f), zero = _mm_setzero_ps();
    const __m128 fx =
        _mm_min_ps(_mm_set1_ps(w - 1.0f),
                   _mm_max_ps(zero, _mm_sub_ps(axis4(m.x, m.ax, m.bx, m.cx, u, v), half)));
    const __m128 fy =
        _mm_min_ps(_mm_set1_ps(h - 1.0f),
                   _mm_max_ps(zero, _mm_sub_ps(axis4(m.y, m.ay, m.by, m.cy, u, v), half)));
    const __m128i x0 = _mm_min_epi32(_mm_cvttps_epi32(fx), _mm_set1_epi32(w - 2));
    const __m128i y0 = _mm_min_epi32(_mm_cvttps_epi32(fy), _mm_set1_epi32(h - 2));
    return detail::taps4(x0, y0, w, _mm_sub_ps(fx, _mm_cvtepi32_ps(x0)),
                         _mm_sub_ps(fy, _mm_cvtepi32_ps(y0)));
}

// Pixels [n, n + 4) of a run: plane c of the rendered values at planes[c], c < 4 G.
template <int G>
TESSWAVE_AVX2 void rendered4(const RenderRun& run, int32_t n, __m128* planes) {
    for (int g = 0; g < G; ++g) {
        const float* v = run.values + static_cast<size_t>(n) * run.stride + 4 * g;
        __m128 p0 = _mm_load_ps(v), p1 = _mm_load_ps(v + run.stride);
        __m128 p2 = _mm_load_ps(v + 2 * run.stride), p3 = _mm_load_ps(v + 3 * run.stride);
        _MM_TRANSPOSE4_PS(p0, p1, p2, p3);
        planes[4 * g] = p0, planes[4 * g + 1] = p1, planes[4 * g + 2] = p2, planes[4 * g + 3] = p3;
    }
}

// A run of compose four pixels at a time (the last four may overlap the four before, which then
// get the same values again). Returns how many pixels it did: all, or none below four.
template <int Ch, int Weights, bool Both>
[[gnu::target("avx2")]] int32_t compose_run_avx2(const RenderRun& run, const ResidualWarp& w,
                                                 float* const* out) {
    if (run.length < 4) return 0;
    constexpr int G = (Ch + Weights + 3) / 4;
    const QuadMap& ma = w.maps_a[run.quad];
    const QuadMap& mb = w.maps_b[run.quad];
    for (int32_t next = 0; next < run.length; next += 4) {
        const int32_t n = std::min(next, run.length - 4);
        const __m128 u = _mm_loadu_ps(run.u + n), v = _mm_loadu_ps(run.v + n);
        __m128 rendered[4 * G];
        rendered4<G>(run, n, rendered);
        const detail::Taps4 ta = taps4(ma, u, v, w.ra.width, w.ra.height);
        if constexpr (!Both) {
            const __m128 ka = _mm_set1_ps(w.ka);
            for (int c = 0; c < Ch; ++c) {
                const __m128 a = detail::bilinear4(w.ra.planes[c].data(), ta);
                _mm_storeu_ps(out[c] + run.start + n, _mm_add_ps(rendered[c], _mm_mul_ps(ka, a)));
            }
        } else {
            const detail::Taps4 tb = taps4(mb, u, v, w.rb.width, w.rb.height);
            const __m128 wa = Weights == 2 ? rendered[Ch] : _mm_set1_ps(w.ka);
            const __m128 wb = Weights == 2 ? rendered[Ch + 1] : _mm_set1_ps(w.kb);
            for (int c = 0; c < Ch; ++c) {
                const __m128 a = detail::bilinear4(w.ra.planes[c].data(), ta);
                const __m128 b = detail::bilinear4(w.rb.planes[c].data(), tb);
                _mm_storeu_ps(
                    out[c] + run.start + n,
                    _mm_add_ps(rendered[c], _mm_add_ps(_mm_mul_ps(wa, a), _mm_mul_ps(wb, b))));
            }
        }
    }
    return run.length;
}

// warped_through's fetch, four pixels at a time as compose_run_avx2.
[[gnu::target("avx2")]] int32_t fetch_run_avx2(const RenderRun& run, const QuadMap& m,
                                               const Image& b, float* const* out) {
    if (run.length < 4) return 0;
    for (int32_t next = 0; next < run.length; next += 4) {
        const int32_t n = std::min(next, run.length - 4);
        const detail::Taps4 t =
            taps4(m, _mm_loadu_ps(run.u + n), _mm_loadu_ps(run.v + n), b.width, b.height);
        for (int c = 0; c < b.channels(); ++c)
            _mm_storeu_ps(out[c] + run.start + n, detail::bilinear4(b.planes[c].data(), t));
    }
    return run.length;
}

#undef TESSWAVE_AVX2
#endif

// Whether the four-pixel kernels may run on images of this size (see taps4).
bool vector_fetch(const Image& image) {
#if defined(__x86_64__)
    static const bool avx2 = __builtin_cpu_supports("avx2");
    return avx2 && image.width >= 2 && image.height >= 2 && image.width < (1 << 22) &&
           image.height < (1 << 22);
#else
    (void)image;
    return false;
#endif
}

template <int Ch, int Weights, bool Both>
void compose_with(const RenderPlan& plan, std::span<const std::span<const float>> planes,
                  const ResidualWarp& w, Image& out) {
    const std::vector<float*> to = plane_pointers(out);
    const bool vector = vector_fetch(w.ra) && vector_fetch(w.rb);
    render_runs<Ch + Weights, true>(plan, planes, [&](const RenderRun& run) {
        int32_t n = 0;
#if defined(__x86_64__)
        if (vector) n = compose_run_avx2<Ch, Weights, Both>(run, w, to.data());
#endif
        for (; n < run.length; ++n) {
            const float* v = run.values + static_cast<size_t>(n) * run.stride;
            const int32_t px = run.start + n;
            const Tap ta = bilinear_tap(w.ra.width, w.ra.height, 1.0,
                                        w.maps_a[run.quad].at(run.u[n], run.v[n]));
            if constexpr (!Both) {
                for (int c = 0; c < Ch; ++c)
                    to[c][px] = v[c] + w.ka * bilinear_at(ta, w.ra.planes[c].data());
            } else {
                const Tap tb = bilinear_tap(w.rb.width, w.rb.height, 1.0,
                                            w.maps_b[run.quad].at(run.u[n], run.v[n]));
                const float wa = Weights == 2 ? v[Ch] : w.ka, wb = Weights == 2 ? v[Ch + 1] : w.kb;
                for (int c = 0; c < Ch; ++c) {
                    to[c][px] = v[c] + (wa * bilinear_at(ta, w.ra.planes[c].data()) +
                                        wb * bilinear_at(tb, w.rb.planes[c].data()));
                }
            }
        }
    });
}

template <int Ch>
void compose_channels(const RenderPlan& plan, std::span<const std::span<const float>> planes,
                      const ResidualWarp& w, Image& out) {
    if (!w.both) return compose_with<Ch, 0, false>(plan, planes, w, out);
    if (w.per_sample_weights) return compose_with<Ch, 2, true>(plan, planes, w, out);
    compose_with<Ch, 0, true>(plan, planes, w, out);
}

}  // namespace

void compose(const RenderPlan& plan, std::span<const std::span<const float>> planes,
             const ResidualWarp& w, Image& out) {
    const int channels = out.channels();
    const size_t needed = static_cast<size_t>(channels) + (w.per_sample_weights ? 2 : 0);
    if ((channels != 3 && channels != 4) || planes.size() != needed || w.ra.channels() < channels ||
        w.rb.channels() < channels || (w.per_sample_weights && !w.both)) {
        throw Error(
            str("morph: cannot compose ", planes.size(), " planes into ", channels, " channels"));
    }
    if (channels == 4) return compose_channels<4>(plan, planes, w, out);
    compose_channels<3>(plan, planes, w, out);
}

Image warped_through(const RenderPlan& plan, std::span<const QuadMap> quads, const Image& b) {
    Image out = make_image(plan.width, plan.height, b.channels(), SampleFormat::f32);
    const std::vector<float*> to = plane_pointers(out);
    const bool vector = vector_fetch(b);
    render_runs<0, true>(plan, {}, [&](const RenderRun& run) {
        int32_t n = 0;
#if defined(__x86_64__)
        if (vector) n = fetch_run_avx2(run, quads[run.quad], b, to.data());
#endif
        for (; n < run.length; ++n) {
            const Tap tap =
                bilinear_tap(b.width, b.height, 1.0, quads[run.quad].at(run.u[n], run.v[n]));
            for (int c = 0; c < b.channels(); ++c)
                to[c][run.start + n] = bilinear_at(tap, b.planes[c].data());
        }
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
