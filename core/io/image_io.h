// Image files through OpenImageIO (PNG, JPEG, TIFF, EXR, PNM, ... by extension).
#pragma once

#include <string>

#include "core/math/image.h"

namespace tesswave {

struct ImageLimits {
    int64_t max_pixels = 400'000'000;
    int max_channels = 4;  // extra channels beyond 4 are dropped
};

// Throws Error("<path>: ...") for unreadable files and sizes beyond the limits.
Image read_image(const std::string& path, const ImageLimits& limits = {});

// Atomic: writes a temporary beside `path`, renames on success. Values are clamped to [0,1] for
// integer formats; the format falls back to 8 bit where the file type has no 16-bit or float.
void write_image(const Image& image, const std::string& path);

}  // namespace tesswave
