#include "core/io/image_io.h"

#include <dlfcn.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <utility>
#include <vector>

#include "core/io/file_io.h"
#include "core/io/image_plugin.h"
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

// The module with the OpenImageIO calls, loaded on first use: beside the executable (a copied
// build), else where the build put it. Sanitizer builds link it in (CMakeLists.txt says why).
const detail::ImagePlugin* load_plugin([[maybe_unused]] std::string& error) {
#ifndef TESSWAVE_IMAGE_PLUGIN
    return tesswave_image_plugin();  // linked in (a sanitizer build)
#else
    constexpr const char* kName = "libtesswave_image_oiio.so";
    std::vector<std::string> candidates;
    std::error_code ec;
    const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (!ec) candidates.push_back((exe.parent_path() / kName).string());
    candidates.emplace_back(TESSWAVE_IMAGE_PLUGIN);
    for (const std::string& path : candidates) {
        if (!std::filesystem::exists(path, ec)) continue;
        // DEEPBIND: the module's 260 libraries look up their symbols among themselves first,
        // not after the executable's 190 (a Kodak decompress: 0.74 -> 0.58 s). Nothing here is
        // interposed by the executable (no malloc or operator new of its own).
        void* module = ::dlopen(path.c_str(), RTLD_LAZY | RTLD_LOCAL | RTLD_DEEPBIND);
        if (!module) {
            const char* why = ::dlerror();
            error = why ? why : path + ": cannot be loaded";  // dlerror names the file
            return nullptr;
        }
        using Entry = const detail::ImagePlugin* (*)();
        auto entry = reinterpret_cast<Entry>(::dlsym(module, "tesswave_image_plugin"));
        if (!entry) {
            error = str(path, ": not tesswave's image module");
            return nullptr;
        }
        return entry();  // the module stays loaded for the life of the process
    }
    error = str(kName, " is neither beside the executable nor at ", TESSWAVE_IMAGE_PLUGIN);
    return nullptr;
#endif
}

// The module, loaded once; throws Error naming `path` (the image the caller wanted) when it
// cannot be loaded.
const detail::ImagePlugin& plugin(const std::string& path) {
    static std::string error;
    static const detail::ImagePlugin* const loaded = load_plugin(error);
    if (!loaded) throw Error(str(path, ": image files cannot be read or written: ", error));
    return *loaded;
}

}  // namespace

Image read_image(const std::string& path, const ImageLimits& limits, ImageNotes* notes) {
    const detail::ImagePlugin& oiio = plugin(path);
    QuietStderr quiet;
    detail::ImageFileSpec spec;
    std::string why;
    std::unique_ptr<void, void (*)(void*)> in(oiio.open(path, spec, why), oiio.close);
    if (!in) {
        throw Error(str(path, ": cannot read image (", why.empty() ? "unknown format" : why, ")"));
    }
    if (spec.width <= 0 || spec.height <= 0 || spec.channels <= 0) {
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
    const int channels = std::min(spec.channels, limits.max_channels);
    if (limits.check_size) {
        try {
            limits.check_size(spec.width, spec.height, channels);
        } catch (const Error& e) {
            throw Error(str(path, ": ", e.what()));
        }
    }
    std::vector<float> pixels(static_cast<size_t>(spec.width) * spec.height * channels);
    std::string warning;
    if (!oiio.read_pixels(in.get(), channels, pixels.data(), why, warning)) {
        throw Error(str(path, ": cannot decode image (", why, ")"));
    }
    Image image = make_image(spec.width, spec.height, channels, spec.format);
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
        notes->decoder = std::move(warning);
    }
    return image;
}

bool image_writable(const std::string& path) {
    // The common kinds are answered without loading the image module (a hundred megabytes of
    // libraries): a command refused for its input then costs no more than the command itself.
    const std::string ext = lowercase_extension(path);
    for (const char* known : {".png", ".tif", ".tiff", ".jpg", ".jpeg", ".exr"}) {
        if (ext == known) return true;
    }
    return plugin(path).writable(path);
}

void write_image(const Image& image, const std::string& path) {
    const int channels = image.channels();
    if (image.width <= 0 || image.height <= 0 || channels <= 0) {
        throw Error(path + ": nothing to write (empty image)");
    }
    const detail::ImagePlugin& oiio = plugin(path);
    const size_t n = static_cast<size_t>(image.width) * image.height;
    std::vector<float> pixels(n * channels);
    for (size_t i = 0; i < n; ++i) {
        for (int c = 0; c < channels; ++c) pixels[i * channels + c] = image.planes[c][i];
    }
    const detail::ImageFileSpec spec{image.width, image.height, channels, image.format};
    const std::string tmp = temporary_name(path);
    std::string why;
    if (!oiio.write(path, tmp, spec, pixels.data(), why)) {
        discard_temporary(tmp);
        throw Error(str(path, ": ", why));
    }
    commit_temporary(tmp, path);
}

}  // namespace tesswave
