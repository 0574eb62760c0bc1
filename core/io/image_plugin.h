// The interface between image_io.cpp and the module that holds its OpenImageIO calls
// (image_oiio.cpp, built as libtesswave_image_oiio.so and loaded with dlopen on first use).
// OpenImageIO and what Debian's build of it links (about 260 libraries: GDAL, GDCM and Poppler
// come in through its OpenCV support) cost every process about 0.3 s of dynamic linking and
// 100 MB at start-up; a process that reads or writes no image file (decode, info, an encode
// from a video file, --help) does not load them. Internal to the io layer.
#pragma once

#include <string>

#include "core/math/image.h"

namespace tesswave::detail {

struct ImageFileSpec {
    int width = 0, height = 0, channels = 0;
    SampleFormat format = SampleFormat::u8;
};

struct ImagePlugin {
    // Opens `path` and reads its header (alpha unassociated, as stored). Returns a handle for
    // read_pixels and close, or nullptr with `error` set to the reader's reason.
    void* (*open)(const std::string& path, ImageFileSpec& spec, std::string& error);
    // The first `channels` channels of every pixel as float, interleaved. On success `warning`
    // holds the decoder's complaint about a file it still read (a truncated JPEG), if any.
    bool (*read_pixels)(void* handle, int channels, float* pixels, std::string& error,
                        std::string& warning);
    void (*close)(void* handle);
    // Whether there is a writer for the extension of `path`.
    bool (*writable)(const std::string& path);
    // Writes `pixels` (interleaved, spec.channels) into `file`, choosing the writer by the
    // extension of `name` (file is a temporary beside it); f32 falls back to u16 where the
    // format has no float. For an integer format the values are clamped to [0, 1] in place.
    bool (*write)(const std::string& name, const std::string& file, const ImageFileSpec& spec,
                  float* pixels, std::string& error);
};

}  // namespace tesswave::detail

// The one symbol the module exports.
extern "C" const tesswave::detail::ImagePlugin* tesswave_image_plugin();
