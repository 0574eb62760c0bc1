#include "core/eval/plot.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/io/opencv_image.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

// Okabe & Ito, "Color Universal Design" (2008): told apart under the common colour-vision
// deficiencies. Yellow comes last because it is faint on white.
constexpr std::array<uint32_t, 8> kPalette = {0x0072B2, 0xD55E00, 0x009E73, 0xCC79A7,
                                              0xE69F00, 0x56B4E9, 0x000000, 0xF0E442};
constexpr int kShift = 4;  // sub-pixel bits of the OpenCV drawing calls
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
const cv::Scalar kInk(0, 0, 0), kGrid(228, 228, 228), kFrame(110, 110, 110), kWhite(255, 255, 255);

// Markers in units of their radius (y down): a circle, four filled polygons, two pairs of strokes.
// Seven kinds, coprime to the palette's eight colours: a pair repeats only after 56 series.
const std::vector<std::vector<cv::Point2d>> kMarkers = {
    {},
    {{-.85, -.85}, {.85, -.85}, {.85, .85}, {-.85, .85}},
    {{0, -1.2}, {1.1, .8}, {-1.1, .8}},
    {{0, -1.25}, {1.25, 0}, {0, 1.25}, {-1.25, 0}},
    {{0, 1.2}, {1.1, -.8}, {-1.1, -.8}},
    {{-1, -1}, {1, 1}, {-1, 1}, {1, -1}},
    {{-1.2, 0}, {1.2, 0}, {0, -1.2}, {0, 1.2}}};

cv::Scalar bgr(size_t index) {
    const uint32_t c = kPalette[index % kPalette.size()];
    return cv::Scalar(c & 255, (c >> 8) & 255, c >> 16);
}

cv::Point fixed(cv::Point2d p) {
    return cv::Point(static_cast<int>(std::lround(p.x * (1 << kShift))),
                     static_cast<int>(std::lround(p.y * (1 << kShift))));
}

struct Font {
    double scale;
    int thickness;
};

struct Style {
    Font tick, label, title;
    int pad, gap, tick_len, line, marker;
};

// Width, and height including the descent below the baseline.
cv::Size text_size(const std::string& s, const Font& f, int* ascent = nullptr) {
    int descent = 0;
    const cv::Size sz = cv::getTextSize(s, kFont, f.scale, f.thickness, &descent);
    if (ascent) *ascent = sz.height;
    return {sz.width, sz.height + descent};
}

// Draws `s` with the point (ax, ay) of its box, in fractions of its size, at `at`.
void put_text(cv::Mat& m, const std::string& s, cv::Point2d at, double ax, double ay,
              const Font& f) {
    int ascent = 0;
    const cv::Size sz = text_size(s, f, &ascent);
    const cv::Point2d origin(at.x - ax * sz.width, at.y - ay * sz.height + ascent);
    cv::putText(m, s, cv::Point(origin), kFont, f.scale, kInk, f.thickness, cv::LINE_AA);
}

// `f` shrunk so that `s` fits in `room` pixels (to no less than a third; beyond that it clips).
Font fit(const std::string& s, Font f, int room) {
    const int w = text_size(s, f).width;
    if (w > room) f.scale *= std::max(0.35, static_cast<double>(room) / w);
    return f;
}

struct Range {
    double lo, hi;
};

struct Axis {
    Range range;                // in axis units: log2 of the data on a log axis
    std::vector<double> ticks;  // in data units
    std::vector<std::string> labels;
};

bool usable(double x, double y, bool log_x) {
    return std::isfinite(x) && std::isfinite(y) && (!log_x || x > 0);
}

// The usable values' range in axis units, padded by 5%, never empty.
Range axis_range(const std::vector<PlotSeries>& series, bool x_axis, bool log_x) {
    const bool log = x_axis && log_x;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const PlotSeries& s : series) {
        for (size_t i = 0; i < s.x.size(); ++i) {
            if (!usable(s.x[i], s.y[i], log_x)) continue;
            const double v = !x_axis ? s.y[i] : log ? std::log2(s.x[i]) : s.x[i];
            lo = std::min(lo, v);
            hi = std::max(hi, v);
        }
    }
    if (lo > hi) return log ? Range{-1, 1} : Range{0, 1};
    const double span = hi - lo;
    if (span <= 1e-9 * std::max(std::abs(lo), std::abs(hi))) {
        const double mid = lo + 0.5 * span;
        const double half = log ? 1.0 : mid != 0 ? 0.05 * std::abs(mid) : 0.5;
        lo = mid - half;
        hi = mid + half;
    } else {
        lo -= 0.05 * span;
        hi += 0.05 * span;
    }
    if (!std::isfinite(hi - lo)) {
        throw Error(str("plot: the ", x_axis ? "x" : "y", " values span more than a double holds"));
    }
    return {lo, hi};
}

// Multiples of the 1-2-5 step nearest to giving `target` intervals over `r`.
std::vector<double> linear_ticks(Range r, int target) {
    const double raw = (r.hi - r.lo) / target;
    const double mag = std::pow(10.0, std::floor(std::log10(raw)));
    const double f = raw / mag;
    const double step = (f < 1.5 ? 1 : f < 3.5 ? 2 : f < 7.5 ? 5 : 10) * mag;
    std::vector<double> t;
    if (!(step > 0) || !std::isfinite(step)) return t;
    for (double k = std::ceil(r.lo / step); k * step <= r.hi && t.size() < 100; ++k) {
        t.push_back(k * step + 0.0);  // + 0.0 turns -0 into 0
    }
    return t;
}

// Powers of two while they are few (0.25, 0.5, 1, 2), else 1-2-5 or whole decades (draw_axes
// thins their labels), else (for ranges narrower than that) linear ticks.
std::vector<double> log_ticks(Range r, int target) {
    std::vector<double> t;
    if (r.hi - r.lo <= 2.0 * target) {
        for (double k = std::ceil(r.lo); k <= r.hi; ++k) t.push_back(std::exp2(k));
    }
    if (t.size() >= 2) return t;
    t.clear();
    const double lo = std::max(std::exp2(r.lo), std::numeric_limits<double>::denorm_min());
    const double hi = std::min(std::exp2(r.hi), std::numeric_limits<double>::max());
    const double decades = std::log10(hi) - std::log10(lo);
    const bool dense = 3 * decades <= 2 * target;
    for (double d = std::floor(std::log10(lo)); d <= std::ceil(std::log10(hi)); ++d) {
        for (double m : {1.0, 2.0, 5.0}) {
            const double v = m * std::pow(10.0, d);
            if (v >= lo && v <= hi && (m == 1 || dense)) t.push_back(v);
        }
    }
    return t.size() >= 2 ? t : linear_ticks({lo, hi}, std::max(2, target / 2));
}

// Labels by str(): its 10 significant digits hide the rounding noise of k * step.
Axis make_axis(const std::vector<PlotSeries>& series, bool x_axis, bool log_x, int target) {
    const Range r = axis_range(series, x_axis, log_x);
    Axis a{r, x_axis && log_x ? log_ticks(r, target) : linear_ticks(r, target), {}};
    for (double v : a.ticks) a.labels.push_back(str(v));
    return a;
}

// Pixel positions of data inside the plot area.
struct Frame {
    cv::Rect area;
    Range x, y;  // in axis units
    bool log_x;
    double px(double v) const {
        return area.x + ((log_x ? std::log2(v) : v) - x.lo) / (x.hi - x.lo) * area.width;
    }
    double py(double v) const { return area.y + (y.hi - v) / (y.hi - y.lo) * area.height; }
};

cv::Rect plot_area(const PlotOptions& o, const Axis& xa, const Axis& ya, const Style& st,
                   int legend_width) {
    int y_labels = 0;
    for (const std::string& s : ya.labels)
        y_labels = std::max(y_labels, text_size(s, st.tick).width);
    const int tick_h = text_size("0", st.tick).height, label_h = text_size("Ag", st.label).height;
    const int left =
        st.pad + (o.y_label.empty() ? 0 : label_h + st.pad) + y_labels + st.gap + st.tick_len;
    const int top =
        st.pad + (o.title.empty() ? tick_h / 2 : text_size("Ag", st.title).height + st.pad);
    const int bottom =
        st.tick_len + st.gap + tick_h + (o.x_label.empty() ? 0 : st.gap + label_h) + st.pad;
    const int overhang = xa.labels.empty() ? 0 : text_size(xa.labels.back(), st.tick).width / 2;
    const int right = std::max(st.pad, overhang + 4) + (legend_width ? legend_width + st.pad : 0);
    return {left, top, std::max(1, o.width - left - right), std::max(1, o.height - top - bottom)};
}

void draw_axes(cv::Mat& m, const Frame& fr, const Axis& xa, const Axis& ya, const Style& st) {
    const cv::Rect& a = fr.area;
    auto hair = [&](double x0, double y0, double x1, double y1, const cv::Scalar& c) {
        cv::line(m, fixed({x0, y0}), fixed({x1, y1}), c, 1, cv::LINE_AA, kShift);
    };
    const double l = a.x, r = a.br().x, t = a.y, b = a.br().y;
    std::vector<double> xs;
    for (double v : xa.ticks) xs.push_back(fr.px(v));
    for (double x : xs) {
        hair(x, t + 0.5, x, b - 0.5, kGrid);
        hair(x, b - 0.5, x, b + st.tick_len, kFrame);
    }
    for (size_t i = 0; i < ya.ticks.size(); ++i) {
        const double y = fr.py(ya.ticks[i]);
        hair(l + 0.5, y, r - 0.5, y, kGrid);
        hair(l - st.tick_len, y, l - 0.5, y, kFrame);
        put_text(m, ya.labels[i], {l - st.tick_len - st.gap, y}, 1, 0.5, st.tick);
    }
    cv::rectangle(m, a, kFrame, 1);
    // Label every n-th x tick so that neighbouring labels keep a gap.
    double widest = 0, room = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < xs.size(); ++i) {
        widest = std::max(widest, text_size(xa.labels[i], st.tick).width + 2.0 * st.gap);
        if (i > 0) room = std::min(room, xs[i] - xs[i - 1]);
    }
    const auto every = static_cast<size_t>(std::max(1.0, std::ceil(widest / std::max(room, 1.0))));
    for (size_t i = 0; i < xs.size(); i += every) {
        put_text(m, xa.labels[i], {xs[i], b + st.tick_len + st.gap}, 0.5, 0, st.tick);
    }
}

void draw_titles(cv::Mat& m, const cv::Rect& a, const PlotOptions& o, const Style& st) {
    if (!o.title.empty()) {
        put_text(m, o.title, {0.5 * o.width, st.pad + 0.0}, 0.5, 0,
                 fit(o.title, st.title, o.width - 2 * st.pad));
    }
    if (!o.x_label.empty()) {
        put_text(m, o.x_label, {a.x + 0.5 * a.width, o.height - st.pad + 0.0}, 0.5, 1,
                 fit(o.x_label, st.label, a.width));
    }
    if (!o.y_label.empty()) {  // drawn level, turned, and laid over the canvas darkest-wins
        const Font f = fit(o.y_label, st.label, o.height - 2 * st.pad);
        const cv::Size sz = text_size(o.y_label, f);
        cv::Mat level(sz.height + 2, sz.width + 2, CV_8UC3, kWhite), turned;
        put_text(level, o.y_label, {1, 1}, 0, 0, f);
        cv::rotate(level, turned, cv::ROTATE_90_COUNTERCLOCKWISE);
        const int top = a.y + a.height / 2 - turned.rows / 2;
        const cv::Rect dst =
            cv::Rect(st.pad, top, turned.cols, turned.rows) & cv::Rect({}, m.size());
        cv::Mat roi = m(dst);
        cv::min(roi, turned(dst - cv::Point(st.pad, top)), roi);
    }
}

void draw_marker(cv::Mat& m, cv::Point2d p, size_t index, double r, const cv::Scalar& c) {
    const size_t kind = index % kMarkers.size();
    if (kind == 0) {
        const int radius = static_cast<int>(std::lround(r * (1 << kShift)));
        cv::circle(m, fixed(p), radius, c, cv::FILLED, cv::LINE_AA, kShift);
        return;
    }
    std::vector<cv::Point> q;
    for (cv::Point2d v : kMarkers[kind]) q.push_back(fixed(p + v * r));
    if (kind < 5) return cv::fillConvexPoly(m, q, c, cv::LINE_AA, kShift);
    const int thick = std::max(2, static_cast<int>(std::lround(r / 2.5)));
    cv::line(m, q[0], q[1], c, thick, cv::LINE_AA, kShift);
    cv::line(m, q[2], q[3], c, thick, cv::LINE_AA, kShift);
}

// Each series' usable points in pixels.
std::vector<std::vector<cv::Point2d>> project(const std::vector<PlotSeries>& series,
                                              const Frame& fr) {
    std::vector<std::vector<cv::Point2d>> out(series.size());
    for (size_t k = 0; k < series.size(); ++k) {
        const PlotSeries& s = series[k];
        for (size_t i = 0; i < s.x.size(); ++i) {
            if (usable(s.x[i], s.y[i], fr.log_x)) out[k].push_back({fr.px(s.x[i]), fr.py(s.y[i])});
        }
    }
    return out;
}

// How many curve segments pass through `box`.
int covered(const std::vector<std::vector<cv::Point2d>>& curves, const cv::Rect& box) {
    int n = 0;
    for (const auto& c : curves) {
        for (size_t i = 0; i < c.size(); ++i) {
            cv::Point a(c[i]), b(c[std::min(i + 1, c.size() - 1)]);
            n += cv::clipLine(box, a, b);
        }
    }
    return n;
}

// The legend's box inside the plot area, in the corner that hides the least of the curves, and
// how much it hides.
std::pair<cv::Rect, int> place_legend(const std::vector<std::vector<cv::Point2d>>& curves,
                                      const cv::Rect& a, cv::Size size, int inset) {
    const int l = a.x + inset, r = a.br().x - inset - size.width;
    const int t = a.y + inset, b = a.br().y - inset - size.height;
    cv::Rect best;
    int best_n = std::numeric_limits<int>::max();
    for (cv::Point p : {cv::Point(r, b), cv::Point(l, t), cv::Point(r, t), cv::Point(l, b)}) {
        const cv::Rect box(p, size);
        const int n = covered(
            curves, {box.x - inset, box.y - inset, box.width + 2 * inset, box.height + 2 * inset});
        if (n < best_n) best = box, best_n = n;
    }
    return {best, best_n};
}

void draw_legend(cv::Mat& m, const std::vector<PlotSeries>& series, const cv::Rect& box,
                 const Style& st) {
    cv::rectangle(m, box, kWhite, cv::FILLED);
    cv::rectangle(m, box, kFrame, 1);
    const double row = (box.height - st.gap) / static_cast<double>(series.size());
    const double sample = 3.5 * st.marker;
    for (size_t k = 0; k < series.size(); ++k) {
        const double y = box.y + st.gap / 2.0 + (k + 0.5) * row, x = box.x + st.gap;
        cv::line(m, fixed({x, y}), fixed({x + sample, y}), bgr(k), st.line, cv::LINE_AA, kShift);
        draw_marker(m, {x + sample / 2, y}, k, st.marker, bgr(k));
        put_text(m, series[k].name, {x + sample + st.gap, y}, 0, 0.5, st.tick);
    }
}

Image to_image(const cv::Mat& bgr8) {
    cv::Mat bgr;
    bgr8.convertTo(bgr, CV_32F, 1 / 255.0);
    Image out = make_image(bgr.cols, bgr.rows, 3);
    for (int c = 0; c < 3; ++c) {
        cv::extractChannel(bgr, cv::Mat(bgr.size(), CV_32F, out.planes[2 - c].data()), c);
    }
    return out;
}

}  // namespace

std::array<float, 3> plot_series_colour(size_t index) {
    const cv::Scalar c = bgr(index);
    return {static_cast<float>(c[2] / 255), static_cast<float>(c[1] / 255),
            static_cast<float>(c[0] / 255)};
}

namespace {

Image line_plot(const std::vector<PlotSeries>& series, const PlotOptions& o) {
    if (o.width < 160 || o.height < 160 || o.width > 8192 || o.height > 8192) {
        throw Error(str("plot: size ", o.width, "x", o.height, " is outside 160..8192"));
    }
    for (const PlotSeries& s : series) {
        if (s.x.size() != s.y.size()) {
            throw Error(str("plot: series \"", s.name, "\" has ", s.x.size(), " x values but ",
                            s.y.size(), " y values"));
        }
    }
    // Sizes follow the image, but stop shrinking where text and markers would become illegible.
    const double u = std::max(0.7, std::min(o.width / 960.0, o.height / 640.0));
    const int thin = std::max(1, static_cast<int>(std::lround(u)));
    auto px = [&](double v) { return std::max(1, static_cast<int>(std::lround(v * u))); };
    const Font title{0.75 * u, std::max(1, static_cast<int>(std::lround(1.5 * u)))};
    const Style st{{0.5 * u, thin}, {0.6 * u, thin}, title, px(14), px(6), px(5), px(2), px(5)};
    const Axis xa = make_axis(series, true, o.log_x, std::max(3, o.width / 130));
    const Axis ya = make_axis(series, false, o.log_x, std::max(3, o.height / 80));

    cv::Size legend;
    for (const PlotSeries& s : series) {
        legend.width = std::max(legend.width, text_size(s.name, st.tick).width);
        legend.height += text_size(s.name + "Ag", st.tick).height + 2 * st.gap;
    }
    legend += cv::Size(static_cast<int>(3.5 * st.marker) + 3 * st.gap, st.gap);
    Frame fr{plot_area(o, xa, ya, st, 0), xa.range, ya.range, o.log_x};
    auto curves = project(series, fr);
    auto [box, hidden] = place_legend(curves, fr.area, legend, st.gap * 2);
    if (hidden > 0 && legend.width < o.width / 3) {  // every corner has data: move outside
        fr.area = plot_area(o, xa, ya, st, legend.width);
        box = cv::Rect({fr.area.br().x + st.pad, fr.area.y}, legend);
        curves = project(series, fr);
    }

    cv::Mat m(o.height, o.width, CV_8UC3, kWhite);
    draw_axes(m, fr, xa, ya, st);
    draw_titles(m, fr.area, o, st);
    for (size_t k = 0; k < curves.size(); ++k) {
        const auto& c = curves[k];
        for (size_t i = 0; i + 1 < c.size(); ++i) {
            cv::line(m, fixed(c[i]), fixed(c[i + 1]), bgr(k), st.line, cv::LINE_AA, kShift);
        }
        for (const cv::Point2d& p : c) draw_marker(m, p, k, st.marker, bgr(k));
    }
    if (!series.empty()) draw_legend(m, series, box, st);
    return to_image(m);
}

}  // namespace

Image draw_line_plot(const std::vector<PlotSeries>& series, const PlotOptions& o) {
    return with_opencv_errors("plot", [&] { return line_plot(series, o); });
}

}  // namespace tesswave
