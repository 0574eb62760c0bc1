#include "core/eval/mesh_draw.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <unordered_set>

#include "core/io/opencv_image.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

struct Segment {
    Vec2 a, b;
    int level;  // 0 for T0; -1 for feature edges
};

// Edges of T_0..T_K with their positions, coarse levels last so they are drawn on top.
std::vector<Segment> segments(const Mesh& mesh, int levels) {
    std::vector<Segment> out;
    if (levels == 0) {  // T0's edges alone: no hierarchy, so vertices may lie past the domain
        for (auto [a, b] : build_edges(mesh).vertices) {
            out.push_back({mesh.vertices[a], mesh.vertices[b], 0});
        }
        for (auto [a, b] : mesh.features) out.push_back({mesh.vertices[a], mesh.vertices[b], -1});
        return out;
    }
    const Hierarchy h = build_hierarchy(mesh, {.levels = levels, .max_samples = 20'000'000});
    const auto p = refine_positions(h, mesh.vertices, levels);
    for (int j = levels; j >= 0; --j) {
        // T_j's edges are the halves and spokes of level j-1; draw only what T_{j-1} lacks.
        for (auto [a, b] : h.levels[j].edge_v) out.push_back({p[a], p[b], j});
    }
    for (auto [a, b] : mesh.features) out.push_back({mesh.vertices[a], mesh.vertices[b], -1});
    return out;
}

double pick_scale(const Mesh& mesh, const DrawOptions& options) {
    if (options.scale > 0) return options.scale;
    return 1024.0 / std::max(mesh.width, mesh.height);
}

// A level whose edges outnumber twice the picture's pixels draws a flat colour at a cost of
// gigabytes (a 2000-cell Voronoi mesh at level 6: 24 M edges, 3.7 GB and 11 s for 1024x768):
// refused before the hierarchy is built.
double picture_pixels(const Mesh& mesh, double scale) {
    return std::max(1.0, mesh.width * scale) * std::max(1.0, mesh.height * scale);
}

bool drawable(const Mesh& mesh, int levels, double scale) {
    if (levels == 0) return true;
    return static_cast<double>(level_counts(mesh, levels)[levels].edges) <=
           2 * picture_pixels(mesh, scale);
}

void check_drawable(const Mesh& mesh, int levels, double scale) {
    if (!drawable(mesh, levels, scale)) {
        const double pixels = picture_pixels(mesh, scale);
        const int64_t edges = level_counts(mesh, levels)[levels].edges;
        throw Error(str("draw: level ", levels, " has ", edges, " edges, more than a picture of ",
                        static_cast<int64_t>(pixels), " pixels can show (draw fewer levels)"));
    }
}

struct Style {
    double r, g, b, width;
};

Style style_of(int level, int levels, double line_width) {
    if (level == -1) return {1.0, 0.25, 0.2, 2.5 * line_width};
    if (level == 0) return {1.0, 0.85, 0.1, 2.5 * line_width};
    // Finer levels fade from light cyan towards a transparent-looking blue-grey.
    const double t = levels > 1 ? (level - 1.0) / (levels - 1.0) : 0.0;
    return {0.35 - 0.15 * t, 0.8 - 0.3 * t, 0.95 - 0.25 * t, line_width};
}

}  // namespace

namespace {

Image draw_mesh_raster(const Mesh& mesh, const DrawOptions& options, const Image* background) {
    const double s = pick_scale(mesh, options);
    const int w = static_cast<int>(std::ceil(mesh.width * s));
    const int h = static_cast<int>(std::ceil(mesh.height * s));
    if (w < 1 || h < 1 || int64_t{w} * h > 100'000'000) {
        throw Error(str("draw: output of ", w, "x", h, " pixels is out of range"));
    }
    check_drawable(mesh, options.levels, s);
    const auto segs = segments(mesh, options.levels);
    cv::Mat canvas(h, w, CV_8UC3, cv::Scalar(24, 24, 24));
    if (background) {
        cv::Mat src(background->height, background->width, CV_8UC3);
        for (int y = 0; y < background->height; ++y) {
            for (int x = 0; x < background->width; ++x) {
                for (int c = 0; c < 3; ++c) {
                    const int plane = std::min(c, background->channels() - 1);
                    const float v = std::clamp(background->at(plane, x, y), 0.0f, 1.0f);
                    src.at<cv::Vec3b>(y, x)[2 - c] = static_cast<uint8_t>(std::lround(v * 255));
                }
            }
        }
        cv::resize(src, canvas, canvas.size(), 0, 0, cv::INTER_AREA);
    }
    constexpr int kShift = 4;  // sub-pixel precision of cv::line
    for (const Segment& seg : segs) {
        const Style st = style_of(seg.level, options.levels, options.line_width);
        auto pt = [&](Vec2 q) {
            return cv::Point(static_cast<int>(std::lround(q.x * s * (1 << kShift))),
                             static_cast<int>(std::lround(q.y * s * (1 << kShift))));
        };
        cv::line(canvas, pt(seg.a), pt(seg.b), cv::Scalar(st.b * 255, st.g * 255, st.r * 255),
                 std::max(1, static_cast<int>(std::lround(st.width))), cv::LINE_AA, kShift);
    }
    Image out = make_image(w, h, 3);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const cv::Vec3b px = canvas.at<cv::Vec3b>(y, x);
            for (int c = 0; c < 3; ++c) out.at(c, x, y) = px[2 - c] / 255.0f;
        }
    }
    return out;
}

}  // namespace

int drawable_levels(const Mesh& mesh, int most, double scale) {
    const double s = pick_scale(mesh, {.scale = scale});
    int levels = std::max(most, 0);
    while (levels > 0 && !drawable(mesh, levels, s)) --levels;
    return levels;
}

Image draw_mesh(const Mesh& mesh, const DrawOptions& options, const Image* background) {
    return with_opencv_errors("mesh drawing",
                              [&] { return draw_mesh_raster(mesh, options, background); });
}

std::string draw_mesh_svg(const Mesh& mesh, const DrawOptions& options,
                          const std::string& background_href) {
    const double s = pick_scale(mesh, options);
    check_drawable(mesh, options.levels, s);
    const auto segs = segments(mesh, options.levels);
    std::string out =
        str("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"", mesh.width * s, "\" height=\"",
            mesh.height * s, "\" viewBox=\"0 0 ", mesh.width, " ", mesh.height, "\">\n");
    if (background_href.empty()) {
        out += "<rect width=\"100%\" height=\"100%\" fill=\"#181818\"/>\n";
    } else {
        std::string href;
        for (char c : background_href) {
            href += c == '&'   ? "&amp;"
                    : c == '"' ? "&quot;"
                    : c == '<' ? "&lt;"
                               : std::string(1, c);
        }
        out += str("<image href=\"", href, "\" x=\"0\" y=\"0\" width=\"", mesh.width,
                   "\" height=\"", mesh.height, "\" preserveAspectRatio=\"none\"/>\n");
    }
    int current = -2;
    for (const Segment& seg : segs) {
        if (seg.level != current) {
            if (current != -2) out += "</g>\n";
            const Style st = style_of(seg.level, options.levels, options.line_width);
            out +=
                str("<g stroke=\"rgb(", std::lround(st.r * 255), ",", std::lround(st.g * 255), ",",
                    std::lround(st.b * 255), ")\" stroke-width=\"", st.width / s,
                    "\" stroke-linecap=\"round\" fill=\"none\" class=\"",
                    seg.level == -1 ? std::string("features") : str("level", seg.level), "\">\n");
            current = seg.level;
        }
        out += str("<line x1=\"", seg.a.x, "\" y1=\"", seg.a.y, "\" x2=\"", seg.b.x, "\" y2=\"",
                   seg.b.y, "\"/>\n");
    }
    if (current != -2) out += "</g>\n";
    return out + "</svg>\n";
}

}  // namespace tesswave
