#include "core/math/image.h"

namespace tesswave {

Image make_image(int width, int height, int channels, SampleFormat format) {
    Image image;
    image.width = width;
    image.height = height;
    image.format = format;
    image.planes.assign(channels, std::vector<float>(static_cast<size_t>(width) * height, 0.0f));
    return image;
}

}  // namespace tesswave
