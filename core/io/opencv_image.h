// Images handed to OpenCV: the 8-bit grey frames its feature detectors, trackers and flow take.
#pragma once

#include <opencv2/core.hpp>

#include "core/math/error.h"
#include "core/math/image.h"

namespace tesswave {

// BT.601 luma of the first three planes (or plane 0 of grey), rounded to 8 bits; NaN becomes 0.
// `out` is reused when it already has the size.
void grey8(const Image& image, cv::Mat& out);
cv::Mat grey8(const Image& image);

// Runs `f`, turning an OpenCV exception (which the libraries never let escape) into an Error
// that starts with `what`.
template <class F>
auto with_opencv_errors(const char* what, F&& f) -> decltype(f()) {
    try {
        return f();
    } catch (const cv::Exception& e) {
        throw Error(std::string(what) + ": OpenCV failed: " + e.what());
    }
}

}  // namespace tesswave
