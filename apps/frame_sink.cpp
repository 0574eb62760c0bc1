#include "frame_sink.h"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <filesystem>

#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave::cli {
namespace {

namespace fs = std::filesystem;

std::string extension(const std::string& path) {
    std::string e = fs::path(path).extension().string();
    for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return e;
}

bool is_video_path(const std::string& path) {
    const std::string e = extension(path);
    return e == ".mp4" || e == ".mov" || e == ".mkv" || e == ".y4m";
}

}  // namespace

bool FrameSink::is_folder_path(const std::string& path) {
    return path.ends_with('/') || extension(path).empty();
}

void FrameSink::check_path(const std::string& path, const std::string& option) {
    if (is_video_path(path) || extension(path) == ".gif" || is_folder_path(path)) return;
    throw CLI::ValidationError(option,
                               str(path,
                                   ": frames go to .mp4, .mov, .mkv, .y4m, .gif or a folder "
                                   "(a path without an extension)"));
}

FrameSink::FrameSink(const std::string& path, int width, int height, double fps,
                     const H264Settings& h264)
    : path_(path), fps_(fps) {
    check_path(path);
    if (extension(path) == ".gif") return;
    if (is_video_path(path)) {
        const std::string e = extension(path);
        const VideoCodec codec = e == ".mkv"   ? VideoCodec::ffv1
                                 : e == ".y4m" ? VideoCodec::rawvideo
                                               : VideoCodec::h264;
        video_ = std::make_unique<VideoWriter>(
            path, width, height,
            VideoWriterOptions{.fps = fps, .codec = codec, .crf = h264.crf, .preset = h264.preset});
        return;
    }
    const fs::path target = fs::path(path).lexically_normal();
    const fs::path name =
        target.filename().empty() ? target.parent_path().filename() : target.filename();
    folder_ = (fs::absolute(target).parent_path() / str(".", name.string(), ".tmp-", ::getpid()))
                  .string();
    std::error_code ec;
    fs::remove_all(folder_, ec);
    try {
        create_folders(folder_);  // noted, so that an interrupted run removes it
    } catch (const Error& e) {
        throw Error(str(path, ": cannot create a folder beside it (", e.what(), ")"));
    }
}

FrameSink::~FrameSink() {
    if (finished_ || folder_.empty()) return;
    std::error_code ec;
    fs::remove_all(folder_, ec);
}

void FrameSink::write(const Image& frame) {
    if (video_) {
        video_->write(frame);
    } else if (folder_.empty()) {
        gif_.push_back(frame);
    } else {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%05lld.png", static_cast<long long>(frames_));
        write_image(frame, (fs::path(folder_) / name).string());
    }
    ++frames_;
}

void FrameSink::finish() {
    if (video_) {
        video_->finish();
    } else if (folder_.empty()) {
        if (frames_ == 0) throw Error(str(path_, ": no frames to write"));
        // Ordered dithering: steady from frame to frame (no crawling noise) and about a tenth
        // smaller than error diffusion.
        write_gif(gif_, path_, fps_, {.dither = "bayer"});
    } else {
        if (frames_ == 0) throw Error(str(path_, ": no frames to write"));
        std::error_code ec;
        fs::remove_all(path_, ec);  // the caller checked that overwriting is allowed
        fs::rename(folder_, path_, ec);
        if (ec) throw Error(str(path_, ": cannot move the frames into place (", ec.message(), ")"));
    }
    finished_ = true;
}

}  // namespace tesswave::cli
