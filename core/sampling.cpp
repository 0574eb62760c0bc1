#include "sampling.h"

#include <algorithm>
#include <cmath>

namespace tesswave {

std::vector<std::vector<float>> sample_bilinear(const Image& image,
                                                std::span<const Vec2> positions) {
    std::vector<std::vector<float>> out(image.channels(), std::vector<float>(positions.size()));
    const double max_x = image.width - 1, max_y = image.height - 1;
    for (size_t i = 0; i < positions.size(); ++i) {
        const double x = std::clamp(positions[i].x - 0.5, 0.0, max_x);
        const double y = std::clamp(positions[i].y - 0.5, 0.0, max_y);
        const int x0 = std::min(static_cast<int>(x), image.width - 2 < 0 ? 0 : image.width - 2);
        const int y0 = std::min(static_cast<int>(y), image.height - 2 < 0 ? 0 : image.height - 2);
        const int x1 = std::min(x0 + 1, image.width - 1), y1 = std::min(y0 + 1, image.height - 1);
        const float tx = static_cast<float>(x - x0), ty = static_cast<float>(y - y0);
        for (int c = 0; c < image.channels(); ++c) {
            const float a = image.at(c, x0, y0), b = image.at(c, x1, y0);
            const float d = image.at(c, x0, y1), e = image.at(c, x1, y1);
            out[c][i] = (a + (b - a) * tx) + ((d + (e - d) * tx) - (a + (b - a) * tx)) * ty;
        }
    }
    return out;
}

}  // namespace tesswave
