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

// One pointer a plane, for kernels that write pixels of every channel.
inline std::vector<float*> plane_pointers(Image& image) {
    std::vector<float*> out(image.planes.size());
    for (size_t c = 0; c < out.size(); ++c) out[c] = image.planes[c].data();
    return out;
}

// Calls f.template operator()<C>() with C = `channels` for 1 to 4, else C = 0 (any count): for
// kernels that keep one pointer per channel in registers.
template <class F>
void with_channel_count(int channels, F&& f) {
    switch (channels) {
        case 1:
            return f.template operator()<1>();
        case 2:
            return f.template operator()<2>();
        case 3:
            return f.template operator()<3>();
        case 4:
            return f.template operator()<4>();
        default:
            return f.template operator()<0>();
    }
}

}  // namespace tesswave
