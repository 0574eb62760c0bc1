#include "core/io/opencv_image.h"

#include <algorithm>
#include <cmath>

namespace tesswave {

void grey8(const Image& image, cv::Mat& out) {
    out.create(image.height, image.width, CV_8UC1);
    const size_t n = static_cast<size_t>(image.width) * image.height;
    for (size_t i = 0; i < n; ++i) {
        double v = image.planes[0][i];
        if (image.channels() >= 3) {
            v = 0.299 * v + 0.587 * image.planes[1][i] + 0.114 * image.planes[2][i];
        }
        v = v > 0 ? std::min(v, 1.0) : 0.0;  // NaN goes to 0
        out.data[i] = static_cast<uint8_t>(std::lround(v * 255));
    }
}

cv::Mat grey8(const Image& image) {
    cv::Mat out;
    grey8(image, out);
    return out;
}

}  // namespace tesswave
