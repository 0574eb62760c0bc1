#include "core/io/opencv_image.h"

#include <gtest/gtest.h>

#include <string>

#include "core/math/error.h"

namespace tesswave {
namespace {

TEST(OpencvImage, an_opencv_exception_becomes_an_error_naming_the_job) {
    try {
        with_opencv_errors("plot", []() -> int {
            cv::Mat small(2, 2, CV_8UC1);
            cv::Mat other(3, 3, CV_8UC1);
            cv::Mat sum = small + other;  // sizes differ: OpenCV throws
            return sum.rows;
        });
        FAIL() << "no exception";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("plot: OpenCV failed: ", 0), 0u) << e.what();
    }
    EXPECT_EQ(with_opencv_errors("plot", [] { return 7; }), 7);
}

TEST(OpencvImage, grey8_is_the_rounded_bt601_luma) {
    Image image = make_image(2, 1, 3);
    image.at(0, 0, 0) = 1.0f;  // pure red: 0.299 * 255 = 76.2
    image.at(1, 1, 0) = 1.0f;  // pure green: 0.587 * 255 = 149.7
    const cv::Mat grey = grey8(image);
    ASSERT_EQ(grey.type(), CV_8UC1);
    EXPECT_EQ(grey.at<uint8_t>(0, 0), 76);
    EXPECT_EQ(grey.at<uint8_t>(0, 1), 150);
}

}  // namespace
}  // namespace tesswave
