#include "core/io/frame_source.h"

extern "C" {
#include <libavutil/imgutils.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string_view>
#include <vector>

#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/io/video_io.h"
#include "core/io/video_libav.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

namespace fs = std::filesystem;

bool is_image_file(const fs::path& path) {
    static const std::array<std::string_view, 10> extensions = {
        ".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".ppm", ".pgm", ".exr", ".webp"};
    const std::string ext = lowercase_extension(path.string());
    return std::find(extensions.begin(), extensions.end(), ext) != extensions.end();
}

// Natural order: runs of digits compare by value (frame2 < frame10), everything else byte by
// byte; names equal that way (frame01, frame1) fall back to plain order, so the order is total.
bool natural_less(const std::string& a, const std::string& b) {
    size_t i = 0, j = 0;
    while (i < a.size() && j < b.size()) {
        const bool da = std::isdigit(static_cast<unsigned char>(a[i]));
        const bool db = std::isdigit(static_cast<unsigned char>(b[j]));
        if (da && db) {
            const size_t ia = i, jb = j;
            while (i < a.size() && std::isdigit(static_cast<unsigned char>(a[i]))) ++i;
            while (j < b.size() && std::isdigit(static_cast<unsigned char>(b[j]))) ++j;
            // Without leading zeros, the longer run is the larger number.
            std::string_view na(a.data() + ia, i - ia), nb(b.data() + jb, j - jb);
            na.remove_prefix(std::min(na.find_first_not_of('0'), na.size()));
            nb.remove_prefix(std::min(nb.find_first_not_of('0'), nb.size()));
            if (na.size() != nb.size()) return na.size() < nb.size();
            if (na != nb) return na < nb;
        } else {
            if (a[i] != b[j])
                return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
            ++i;
            ++j;
        }
    }
    if (i < a.size() || j < b.size()) return j < b.size();  // a prefix comes first
    return a < b;
}

// R, G, B from grey (replicated), grey + alpha, RGB or RGBA (alpha dropped).
void to_rgb(Image& image) {
    if (image.channels() <= 2) {
        image.planes.resize(1);
        image.planes.push_back(image.planes[0]);
        image.planes.push_back(image.planes[0]);
    }
    image.planes.resize(3);
}

struct SwsFree {
    void operator()(SwsContext* context) const { sws_freeContext(context); }
};

// One kind of input. read() returns the next frame, already checked against the first's size.
struct Input {
    virtual ~Input() = default;
    virtual bool read(Image& frame) = 0;

    int width = 0;
    int height = 0;
    double fps = 0;
    int64_t frame_count = -1;
    int64_t trailing_bytes = 0;
    bool subsampled = false;
    // A video file's codec, bit rate (bits a second, 0: unknown) and own frame rate.
    std::string codec;
    int64_t bit_rate = 0;
    double source_fps = 0;
};

class VideoInput : public Input {
  public:
    VideoInput(const std::string& path, const FrameSourceOptions& options)
        : reader_(path, {.max_pixels = options.max_pixels}) {
        width = reader_.width();
        height = reader_.height();
        fps = reader_.fps();
        frame_count = reader_.frame_count_estimate();
        subsampled = reader_.chroma_subsampled();
        codec = reader_.codec_name();
        bit_rate = reader_.bit_rate();
        source_fps = reader_.fps();
    }
    bool read(Image& frame) override { return reader_.read(frame); }

  private:
    VideoReader reader_;
};

class FolderInput : public Input {
  public:
    FolderInput(const std::string& path, const FrameSourceOptions& options)
        : limits_{.max_pixels = options.max_pixels} {
        std::error_code ec;
        for (const fs::directory_entry& entry : fs::directory_iterator(path, ec)) {
            if (entry.is_regular_file(ec) && is_image_file(entry.path())) {
                files_.push_back(entry.path().string());
            }
        }
        if (ec) throw Error(str(path, ": cannot list the folder (", ec.message(), ")"));
        if (files_.empty()) {
            throw Error(path +
                        ": no image files (png, jpg, jpeg, tif, tiff, bmp, ppm, pgm, exr "
                        "or webp) in the folder");
        }
        std::sort(files_.begin(), files_.end(), natural_less);
        first_ = read_image(files_[0], limits_);
        to_rgb(first_);
        width = first_.width;
        height = first_.height;
        frame_count = static_cast<int64_t>(files_.size());
    }

    bool read(Image& frame) override {
        if (next_ >= files_.size()) return false;
        if (next_ == 0) {
            frame = std::move(first_);
        } else {
            frame = read_image(files_[next_], limits_);
            if (frame.width != width || frame.height != height) {
                throw Error(str(files_[next_], ": frame ", next_, " is ", frame.width, "x",
                                frame.height, ", the clip is ", width, "x", height));
            }
            to_rgb(frame);
        }
        ++next_;
        return true;
    }

  private:
    ImageLimits limits_;
    std::vector<std::string> files_;
    size_t next_ = 0;
    Image first_;  // read by the constructor for the size
};

class RawYuvInput : public Input {
  public:
    RawYuvInput(const std::string& path, const FrameSourceOptions& options) : path_(path) {
        const std::string& name = options.pixel_format;
        format_ = av_get_pix_fmt(name.c_str());
        if (format_ != AV_PIX_FMT_YUV420P && format_ != AV_PIX_FMT_YUV422P &&
            format_ != AV_PIX_FMT_YUV444P && format_ != AV_PIX_FMT_GRAY8) {
            throw Error(str(path, ": pixel format '", name,
                            "' is not one of yuv420p, yuv422p, yuv444p and gray"));
        }
        width = options.width;
        height = options.height;
        subsampled = format_ == AV_PIX_FMT_YUV420P || format_ == AV_PIX_FMT_YUV422P;
        if (width <= 0 || height <= 0) {
            throw Error(str(path, ": a raw .yuv file needs its frame size (width and height; got ",
                            width, "x", height, ")"));
        }
        if (width > 65536 || height > 65536 || int64_t{width} * height > options.max_pixels) {
            throw Error(str(path, ": ", width, "x", height, " frames exceed the limit of ",
                            options.max_pixels, " pixels"));
        }
        std::error_code ec;
        const uintmax_t size = fs::file_size(path, ec);
        if (ec) throw Error(str(path, ": cannot read (", ec.message(), ")"));
        frame_bytes_ = av_image_get_buffer_size(format_, width, height, 1);
        libav::check(frame_bytes_, path, "impossible frame size");
        frame_count = static_cast<int64_t>(size / static_cast<uintmax_t>(frame_bytes_));
        trailing_bytes = static_cast<int64_t>(size % static_cast<uintmax_t>(frame_bytes_));
        if (size == 0) throw Error(path + ": empty file");
        if (frame_count == 0) {
            throw Error(str(path, ": ", trailing_bytes, " trailing bytes are not a whole frame of ",
                            width, "x", height, " ", name));
        }
        file_.open(path, std::ios::binary);
        if (!file_) throw Error(path + ": cannot open");
        buffer_.resize(static_cast<size_t>(frame_bytes_));
        rgb_ = libav::alloc_frame(AV_PIX_FMT_GBRP, width, height, path);
        sws_.reset(sws_getContext(width, height, format_, width, height, AV_PIX_FMT_GBRP,
                                  SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT, nullptr,
                                  nullptr, nullptr));
        if (!sws_) throw Error(str(path, ": cannot convert ", name, " to RGB"));
        if (format_ != AV_PIX_FMT_GRAY8) {  // swscale takes gray as full range already
            const int* bt601 = sws_getCoefficients(SWS_CS_ITU601);
            sws_setColorspaceDetails(sws_.get(), bt601, 0, bt601, 1, 0, 1 << 16, 1 << 16);
        }
    }

    bool read(Image& frame) override {
        if (next_ >= frame_count) return false;
        file_.read(reinterpret_cast<char*>(buffer_.data()), frame_bytes_);
        if (file_.gcount() != frame_bytes_) {
            throw Error(str(path_, ": frame ", next_, " is cut short (the file shrank?)"));
        }
        std::array<uint8_t*, 4> data = {};
        std::array<int, 4> linesize = {};
        libav::check(av_image_fill_arrays(data.data(), linesize.data(), buffer_.data(), format_,
                                          width, height, 1),
                     path_, "impossible frame layout");
        sws_scale(sws_.get(), data.data(), linesize.data(), 0, height, rgb_->data, rgb_->linesize);
        libav::image_from_frame(rgb_.get(), frame);
        ++next_;
        return true;
    }

  private:
    std::string path_;
    AVPixelFormat format_ = AV_PIX_FMT_NONE;
    int frame_bytes_ = 0;
    int64_t next_ = 0;
    std::ifstream file_;
    std::vector<uint8_t> buffer_;
    libav::Frame rgb_;
    std::unique_ptr<SwsContext, SwsFree> sws_;
};

}  // namespace

struct FrameSource::State {
    std::unique_ptr<Input> input;
};

FrameSource::FrameSource(const std::string& path, const FrameSourceOptions& options)
    : state_(std::make_unique<State>()) {
    if (!(options.fps >= 0 && options.fps <= 1000)) {
        throw Error(str(path, ": fps ", options.fps, " is not in (0, 1000]"));
    }
    libav::silence();
    std::error_code ec;
    if (!fs::exists(path, ec)) throw Error(path + ": no such file or folder");
    std::unique_ptr<Input>& input = state_->input;
    if (fs::is_directory(path, ec)) {
        input = std::make_unique<FolderInput>(path, options);
        input->fps = 25;
    } else if (lowercase_extension(path) == ".yuv") {
        input = std::make_unique<RawYuvInput>(path, options);
        input->fps = 25;
    } else {
        input = std::make_unique<VideoInput>(path, options);
    }
    if (options.fps > 0) input->fps = options.fps;
}

FrameSource::~FrameSource() = default;
FrameSource::FrameSource(FrameSource&&) noexcept = default;
FrameSource& FrameSource::operator=(FrameSource&&) noexcept = default;

int FrameSource::width() const { return state_->input->width; }
bool FrameSource::chroma_subsampled() const { return state_->input->subsampled; }
std::string FrameSource::source_codec() const { return state_->input->codec; }
double FrameSource::source_bits_per_pixel() const {
    const Input& in = *state_->input;
    const double pixels_per_second = static_cast<double>(in.width) * in.height * in.source_fps;
    return in.bit_rate > 0 && pixels_per_second > 0 ? in.bit_rate / pixels_per_second : 0.0;
}
int FrameSource::height() const { return state_->input->height; }
double FrameSource::fps() const { return state_->input->fps; }
int64_t FrameSource::frame_count_estimate() const { return state_->input->frame_count; }
int64_t FrameSource::trailing_bytes() const { return state_->input->trailing_bytes; }
bool FrameSource::read(Image& frame) { return state_->input->read(frame); }

}  // namespace tesswave
