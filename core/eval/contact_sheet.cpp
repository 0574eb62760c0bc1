#include "core/eval/contact_sheet.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/io/opencv_image.h"
#include "core/math/error.h"

namespace tesswave {

Image centre_crop(const Image& image, int width, int height) {
    const int w = std::min(width, image.width), h = std::min(height, image.height);
    const int x0 = (image.width - w) / 2, y0 = (image.height - h) / 2;
    Image out = make_image(w, h, image.channels(), image.format);
    for (int c = 0; c < image.channels(); ++c) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) out.at(c, x, y) = image.at(c, x0 + x, y0 + y);
        }
    }
    return out;
}

Image crop_scaled(const Image& image, int x0, int y0, int width, int height, double scale) {
    const int x1 = std::clamp(x0 + width, 1, image.width),
              y1 = std::clamp(y0 + height, 1, image.height);
    x0 = std::clamp(x0, 0, x1 - 1);
    y0 = std::clamp(y0, 0, y1 - 1);
    const int w = std::max(1, static_cast<int>(std::lround((x1 - x0) * scale)));
    const int h = std::max(1, static_cast<int>(std::lround((y1 - y0) * scale)));
    if (!(scale > 0) || w > 16384 || h > 16384) throw Error("crop: scale out of range");
    Image out = make_image(w, h, image.channels(), image.format);
    return with_opencv_errors("crop", [&] {
        for (int c = 0; c < image.channels(); ++c) {
            const cv::Mat plane(image.height, image.width, CV_32F,
                                const_cast<float*>(image.planes[c].data()));
            cv::Mat dst(h, w, CV_32F, out.planes[c].data());
            cv::resize(plane(cv::Rect(x0, y0, x1 - x0, y1 - y0)), dst, dst.size(), 0, 0,
                       scale < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
        }
        return out;
    });
}

namespace {

Image draw_contact_sheet(const std::vector<Image>& tiles, const std::vector<std::string>& captions,
                         const ContactSheetOptions& options) {
    if (tiles.empty()) throw Error("contact sheet: no images");
    if (captions.size() != tiles.size()) throw Error("contact sheet: one caption per image");
    const int n = static_cast<int>(tiles.size());
    const int cols = options.columns > 0 ? std::min(options.columns, n) : n;
    const int rows = (n + cols - 1) / cols;
    // Columns as wide as the widest tile; each row as tall as its tallest.
    int cell_w = 1;
    std::vector<int> row_h(rows, 1), row_y(rows + 1, 0);
    for (int i = 0; i < n; ++i) {
        cell_w = std::max(cell_w, tiles[i].width);
        row_h[i / cols] = std::max(row_h[i / cols], tiles[i].height);
    }
    // Captions in a font that fits the column, between 0.35 and 0.8.
    double scale = std::clamp(cell_w / 400.0, 0.4, 0.8);
    int baseline = 0;
    for (const std::string& caption : captions) {
        const int w = cv::getTextSize(caption, cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline).width;
        if (w > cell_w) scale = std::max(0.35, scale * cell_w / w);
    }
    const int text_h = cv::getTextSize("Ag", cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline).height;
    const int caption_h = text_h + baseline + 8, gap = std::max(0, options.gap);
    for (int r = 0; r < rows; ++r) row_y[r + 1] = row_y[r] + row_h[r] + caption_h + gap;
    const int64_t W = int64_t{cols} * (cell_w + gap) + gap;
    const int64_t H = int64_t{row_y[rows]} + gap;
    if (W > 16384 || H > 16384) throw Error("contact sheet: the sheet would exceed 16384 pixels");
    cv::Mat sheet(static_cast<int>(H), static_cast<int>(W), CV_8UC3, cv::Scalar(255, 255, 255));
    for (int i = 0; i < n; ++i) {
        const Image& t = tiles[i];
        const int x0 = gap + (i % cols) * (cell_w + gap), y0 = gap + row_y[i / cols];
        const int cell_h = row_h[i / cols];
        for (int y = 0; y < t.height; ++y) {
            auto* row = sheet.ptr<cv::Vec3b>(y0 + y);
            for (int x = 0; x < t.width; ++x) {
                for (int k = 0; k < 3; ++k) {
                    const float v = t.at(std::min(k, std::min(t.channels(), 3) - 1), x, y);
                    row[x0 + x][2 - k] =
                        static_cast<uint8_t>(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f);
                }
            }
        }
        cv::putText(sheet, captions[i], cv::Point(x0, y0 + cell_h + text_h + 4),
                    cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    }
    Image out = make_image(static_cast<int>(W), static_cast<int>(H), 3);
    for (int y = 0; y < out.height; ++y) {
        const auto* row = sheet.ptr<cv::Vec3b>(y);
        for (int x = 0; x < out.width; ++x) {
            for (int k = 0; k < 3; ++k) out.at(k, x, y) = row[x][2 - k] / 255.0f;
        }
    }
    return out;
}

}  // namespace

Image contact_sheet(const std::vector<Image>& tiles, const std::vector<std::string>& captions,
                    const ContactSheetOptions& options) {
    return with_opencv_errors("contact sheet",
                              [&] { return draw_contact_sheet(tiles, captions, options); });
}

}  // namespace tesswave
