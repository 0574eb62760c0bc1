// The OpenImageIO half of image_io (image_plugin.h says why it is a module of its own).
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cstddef>

#include "core/io/image_plugin.h"

namespace tesswave::detail {
namespace {

void* open_image(const std::string& path, ImageFileSpec& spec, std::string& error) {
    // Alpha stays as stored (straight): no premultiplication on the way in or out.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) {
        error = OIIO::geterror();
        return nullptr;
    }
    const OIIO::ImageSpec& s = in->spec();
    spec.width = s.width;
    spec.height = s.height;
    spec.channels = s.nchannels;
    spec.format = s.format == OIIO::TypeDesc::UINT8            ? SampleFormat::u8
                  : s.format == OIIO::TypeDesc::UINT16         ? SampleFormat::u16
                  : s.format.basetype == OIIO::TypeDesc::UINT8 ? SampleFormat::u8
                                                               : SampleFormat::f32;
    return in.release();
}

bool read_pixels(void* handle, int channels, float* pixels, std::string& error,
                 std::string& warning) {
    auto* in = static_cast<OIIO::ImageInput*>(handle);
    if (!in->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, pixels)) {
        error = in->geterror();
        return false;
    }
    warning = in->has_error() ? in->geterror() : std::string();
    return true;
}

void close_image(void* handle) {
    delete static_cast<OIIO::ImageInput*>(handle);  // closes the file
}

bool writable(const std::string& path) {
    if (OIIO::ImageOutput::create(path)) return true;
    (void)OIIO::geterror();  // the failure is the answer, not an error to report later
    return false;
}

bool write_image(const std::string& name, const std::string& file, const ImageFileSpec& spec,
                 float* pixels, std::string& error) {
    auto out = OIIO::ImageOutput::create(name);
    if (!out) {
        error = "no image writer for this file name (" + OIIO::geterror() + ")";
        return false;
    }
    OIIO::TypeDesc type = spec.format == SampleFormat::u16   ? OIIO::TypeDesc::UINT16
                          : spec.format == SampleFormat::f32 ? OIIO::TypeDesc::FLOAT
                                                             : OIIO::TypeDesc::UINT8;
    if (type == OIIO::TypeDesc::FLOAT && !out->supports("floatformat")) {
        type = OIIO::TypeDesc::UINT16;
    }
    OIIO::ImageSpec s(spec.width, spec.height, spec.channels, type);
    if (spec.channels == 2 || spec.channels == 4) {
        s.alpha_channel = spec.channels - 1;
        s.attribute("oiio:UnassociatedAlpha", 1);
    }
    if (type != OIIO::TypeDesc::FLOAT) {
        const size_t n = static_cast<size_t>(spec.width) * spec.height * spec.channels;
        for (size_t i = 0; i < n; ++i) pixels[i] = std::clamp(pixels[i], 0.0f, 1.0f);
    }
    if (!out->open(file, s) || !out->write_image(OIIO::TypeDesc::FLOAT, pixels) || !out->close()) {
        error = "cannot write image (" + out->geterror() + ")";
        return false;
    }
    return true;
}

constexpr ImagePlugin kPlugin{open_image, read_pixels, close_image, writable, write_image};

}  // namespace
}  // namespace tesswave::detail

extern "C" const tesswave::detail::ImagePlugin* tesswave_image_plugin() {
    return &tesswave::detail::kPlugin;
}
