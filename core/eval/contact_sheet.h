// Pictures side by side with a caption under each (comparisons at equal rate, in-between frames
// beside their truth): one RGB image, tiles in a row-major grid.
#pragma once

#include <string>
#include <vector>

#include "core/math/image.h"

namespace tesswave {

struct ContactSheetOptions {
    int columns = 0;  // 0: all in one row
    int gap = 8;      // pixels between tiles and around the sheet
};

// Every tile is drawn at its own size in a cell as large as the largest tile; grey images are
// shown as grey, alpha is dropped. Throws Error for an empty list or mismatched caption count.
Image contact_sheet(const std::vector<Image>& tiles, const std::vector<std::string>& captions,
                    const ContactSheetOptions& options = {});

// The centred crop of at most width x height pixels.
Image centre_crop(const Image& image, int width, int height);

// The crop [x0, x0 + width) x [y0, y0 + height), clipped to the image, resized to scale times its
// size (area averaging down, bilinear up), for tiles of one size from pictures of another.
Image crop_scaled(const Image& image, int x0, int y0, int width, int height, double scale);

}  // namespace tesswave
