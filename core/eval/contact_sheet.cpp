#include "core/eval/contact_sheet.h"

#include <algorithm>
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

namespace {

Image draw_contact_sheet(const std::vector<Image>& tiles, const std::vector<std::string>& captions,
                         const ContactSheetOptions& options) {
    if (tiles.empty()) throw Error("contact sheet: no images");
    if (captions.size() != tiles.size()) throw Error("contact sheet: one caption per image");
    int cell_w = 1, cell_h = 1;
    for (const Image& t : tiles) {
        cell_w = std::max(cell_w, t.width);
        cell_h = std::max(cell_h, t.height);
    }
    const int n = static_cast<int>(tiles.size());
    const int cols = options.columns > 0 ? std::min(options.columns, n) : n;
    const int rows = (n + cols - 1) / cols;
    const double scale = std::clamp(cell_w / 400.0, 0.4, 0.8);
    int baseline = 0;
    const int text_h = cv::getTextSize("Ag", cv::FONT_HERSHEY_SIMPLEX, scale, 1, &baseline).height;
    const int caption_h = text_h + baseline + 8, gap = std::max(0, options.gap);
    const int64_t W = int64_t{cols} * (cell_w + gap) + gap;
    const int64_t H = int64_t{rows} * (cell_h + caption_h + gap) + gap;
    if (W > 16384 || H > 16384) throw Error("contact sheet: the sheet would exceed 16384 pixels");
    cv::Mat sheet(static_cast<int>(H), static_cast<int>(W), CV_8UC3, cv::Scalar(255, 255, 255));
    for (int i = 0; i < n; ++i) {
        const Image& t = tiles[i];
        const int x0 = gap + (i % cols) * (cell_w + gap),
                  y0 = gap + (i / cols) * (cell_h + caption_h + gap);
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
