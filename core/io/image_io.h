// Image files through OpenImageIO (PNG, JPEG, TIFF, EXR, PNM, ... by extension).
#pragma once

#include <functional>
#include <string>

#include "core/math/image.h"

namespace tesswave {

// Checked against the size a file declares, before its pixels are decoded. A compressed file
// (a PNG of one colour) can declare far more pixels than its bytes hold: any file may declare
// free_pixels; more need a byte of file for each pixels_per_byte pixels, so that a small file
// cannot cost gigabytes (a 1 KB file: at most 5 M pixels). zlib expands at most 1032 times, so
// no PNG of real pixels claims more than about 1000 pixels a byte.
struct ImageLimits {
    int64_t max_pixels = int64_t{1} << 26;  // the .twi limit: nothing larger can be coded
    int64_t free_pixels = int64_t{1} << 22;
    int64_t pixels_per_byte = 1024;
    int max_channels = 4;  // extra channels beyond 4 are dropped
    // The caller's own check of the declared size and channel count (beyond max_channels
    // dropped), run before any pixel is decoded; the Error it throws gets the path in front.
    std::function<void(int width, int height, int channels)> check_size = {};
};

// What reading found that the caller may want to warn about.
struct ImageNotes {
    int64_t non_finite = 0;  // NaN or infinite values, read as 0
    std::string decoder;     // the decoder's complaint about a file it still read (truncation)
};

// Throws Error("<path>: ...") for unreadable files, sizes beyond the limits and images whose
// every value is NaN or infinite (nothing would be left but zeros).
Image read_image(const std::string& path, const ImageLimits& limits = {},
                 ImageNotes* notes = nullptr);

// Atomic: writes a temporary beside `path`, renames on success. Values are clamped to [0,1] for
// integer formats; the format falls back to 8 bit where the file type has no 16-bit or float.
void write_image(const Image& image, const std::string& path);
// Whether write_image has a writer for the path's extension.
bool image_writable(const std::string& path);

}  // namespace tesswave
