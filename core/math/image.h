// Images as planar float buffers: one contiguous plane per channel, values nominally in [0,1]
// (OpenImageIO's convention for integer files). Pixel (i,j) covers [i,i+1)x[j,j+1) and its value
// sits at its centre (i+1/2, j+1/2) (DESIGN.md 2.1).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace tesswave {

enum class SampleFormat : uint8_t { u8, u16, f32 };

struct Image {
    int width = 0;
    int height = 0;
    std::vector<std::vector<float>> planes;  // channels; each width * height, row-major
    SampleFormat format = SampleFormat::u8;  // of the file it came from, kept when writing

    int channels() const { return static_cast<int>(planes.size()); }
    float& at(int c, int x, int y) { return planes[c][static_cast<size_t>(y) * width + x]; }
    float at(int c, int x, int y) const { return planes[c][static_cast<size_t>(y) * width + x]; }
};

Image make_image(int width, int height, int channels, SampleFormat format = SampleFormat::u8);

}  // namespace tesswave
