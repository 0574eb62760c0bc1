#include "core/math/image.h"

namespace tesswave {

Image make_image(int width, int height, int channels, SampleFormat format) {
    Image image;
    image.width = width;
    image.height = height;
    image.format = format;
    // Each plane zeroed in place (assigning copies of one zeroed plane would write each twice).
    image.planes.resize(static_cast<size_t>(channels));
    for (auto& plane : image.planes) plane.resize(static_cast<size_t>(width) * height);
    return image;
}

}  // namespace tesswave
