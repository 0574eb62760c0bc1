#include "core/io/image_io.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/io/file_io.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

// libpng reports decode errors on stderr by itself as well as through OpenImageIO; the library
// never prints, so stderr is pointed at /dev/null while a file is decoded (the error still comes
// back through OpenImageIO and is reported by the caller).
class QuietStderr {
  public:
    QuietStderr() {
        std::fflush(stderr);
        saved_ = ::dup(2);
        const int null = ::open("/dev/null", O_WRONLY);
        if (saved_ >= 0 && null >= 0) ::dup2(null, 2);
        if (null >= 0) ::close(null);
    }
    ~QuietStderr() {
        std::fflush(stderr);
        if (saved_ >= 0) {
            ::dup2(saved_, 2);
            ::close(saved_);
        }
    }
    QuietStderr(const QuietStderr&) = delete;
    QuietStderr& operator=(const QuietStderr&) = delete;

  private:
    int saved_ = -1;
};

}  // namespace

Image read_image(const std::string& path, const ImageLimits& limits, ImageNotes* notes) {
    QuietStderr quiet;
    // Alpha stays as stored (straight): no premultiplication on the way in or out.
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) {
        std::string why = OIIO::geterror();
        throw Error(str(path, ": cannot read image (", why.empty() ? "unknown format" : why, ")"));
    }
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
        throw Error(path + ": image has no pixels");
    }
    const int64_t declared = int64_t{spec.width} * spec.height;
    if (declared > limits.max_pixels) {
        throw Error(str(path, ": ", spec.width, "x", spec.height, " exceeds the limit of ",
                        limits.max_pixels, " pixels"));
    }
    std::error_code ec;
    const auto bytes = static_cast<int64_t>(std::filesystem::file_size(path, ec));
    if (!ec && declared > limits.free_pixels &&
        (declared - limits.free_pixels) / std::max<int64_t>(limits.pixels_per_byte, 1) > bytes) {
        throw Error(str(path, ": declares ", spec.width, "x", spec.height, " pixels in ", bytes,
                        " bytes (more than an image file of that size may claim)"));
    }
    const int channels = std::min(spec.nchannels, limits.max_channels);
    if (limits.check_size) {
        try {
            limits.check_size(spec.width, spec.height, channels);
        } catch (const Error& e) {
            throw Error(str(path, ": ", e.what()));
        }
    }
    const SampleFormat format = spec.format == OIIO::TypeDesc::UINT8            ? SampleFormat::u8
                                : spec.format == OIIO::TypeDesc::UINT16         ? SampleFormat::u16
                                : spec.format.basetype == OIIO::TypeDesc::UINT8 ? SampleFormat::u8
                                                                                : SampleFormat::f32;
    std::vector<float> pixels(static_cast<size_t>(spec.width) * spec.height * channels);
    if (!in->read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, pixels.data())) {
        throw Error(str(path, ": cannot decode image (", in->geterror(), ")"));
    }
    Image image = make_image(spec.width, spec.height, channels, format);
    const size_t n = static_cast<size_t>(spec.width) * spec.height;
    int64_t non_finite = 0;
    for (size_t i = 0; i < n; ++i) {
        for (int c = 0; c < channels; ++c) {
            const float v = pixels[i * channels + c];
            const bool finite = std::isfinite(v);
            non_finite += !finite;
            image.planes[c][i] = finite ? v : 0.0f;
        }
    }
    if (non_finite > 0 && non_finite == static_cast<int64_t>(n) * channels) {
        throw Error(str(path, ": every value is NaN or infinite; there is no image to read"));
    }
    if (notes) {
        notes->non_finite = non_finite;
        notes->decoder = in->has_error() ? in->geterror() : std::string();
    }
    return image;
}

bool image_writable(const std::string& path) {
    if (OIIO::ImageOutput::create(path)) return true;
    (void)OIIO::geterror();  // the failure is the answer, not an error to report later
    return false;
}

void write_image(const Image& image, const std::string& path) {
    const int channels = image.channels();
    if (image.width <= 0 || image.height <= 0 || channels <= 0) {
        throw Error(path + ": nothing to write (empty image)");
    }
    const std::string tmp = temporary_name(path);
    auto out = OIIO::ImageOutput::create(path);
    if (!out)
        throw Error(str(path, ": no image writer for this file name (", OIIO::geterror(), ")"));
    OIIO::TypeDesc type = image.format == SampleFormat::u16   ? OIIO::TypeDesc::UINT16
                          : image.format == SampleFormat::f32 ? OIIO::TypeDesc::FLOAT
                                                              : OIIO::TypeDesc::UINT8;
    if (type == OIIO::TypeDesc::FLOAT && !out->supports("floatformat")) {
        type = OIIO::TypeDesc::UINT16;
    }
    OIIO::ImageSpec spec(image.width, image.height, channels, type);
    if (channels == 2 || channels == 4) {
        spec.alpha_channel = channels - 1;
        spec.attribute("oiio:UnassociatedAlpha", 1);
    }
    const size_t n = static_cast<size_t>(image.width) * image.height;
    std::vector<float> pixels(n * channels);
    const bool clamp = type != OIIO::TypeDesc::FLOAT;
    for (size_t i = 0; i < n; ++i) {
        for (int c = 0; c < channels; ++c) {
            const float v = image.planes[c][i];
            pixels[i * channels + c] = clamp ? std::clamp(v, 0.0f, 1.0f) : v;
        }
    }
    if (!out->open(tmp, spec) || !out->write_image(OIIO::TypeDesc::FLOAT, pixels.data()) ||
        !out->close()) {
        const std::string why = out->geterror();
        discard_temporary(tmp);
        throw Error(str(path, ": cannot write image (", why, ")"));
    }
    commit_temporary(tmp, path);
}

}  // namespace tesswave
