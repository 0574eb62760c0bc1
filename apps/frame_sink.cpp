#include "frame_sink.h"

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>

#include "cli.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave::cli {
namespace {

namespace fs = std::filesystem;

bool is_video_path(const std::string& path) {
    const std::string e = lowercase_extension(path);
    return e == ".mp4" || e == ".mov" || e == ".mkv" || e == ".y4m";
}

}  // namespace

bool FrameSink::is_folder_path(const std::string& path) {
    return path.ends_with('/') || lowercase_extension(path).empty();
}

void FrameSink::check_path(const std::string& path, const std::string& option) {
    if (is_video_path(path) || lowercase_extension(path) == ".gif" || is_folder_path(path)) return;
    throw CLI::ValidationError(option,
                               str(path,
                                   ": frames go to .mp4, .mov, .mkv, .y4m, .gif or a folder "
                                   "(a path without an extension)"));
}

FrameSink::FrameSink(const std::string& path, int width, int height, double fps,
                     const H264Settings& h264)
    : path_(path) {
    check_path(path);
    if (lowercase_extension(path) == ".gif") {
        // Ordered dithering: steady from frame to frame (no crawling noise) and about a tenth
        // smaller than error diffusion.
        gif_ = std::make_unique<GifWriter>(path, width, height, fps, GifOptions{.dither = "bayer"});
        return;
    }
    if (is_video_path(path)) {
        const std::string e = lowercase_extension(path);
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
    } else if (gif_) {
        gif_->write(frame);
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
    } else if (gif_) {
        if (frames_ == 0) throw Error(str(path_, ": no frames to write"));
        gif_->finish();
    } else {
        if (frames_ == 0) throw Error(str(path_, ": no frames to write"));
        move_frames_into_place();
    }
    finished_ = true;
}

// A new folder takes the frames' folder whole. An existing one (the caller checked that
// overwriting is allowed) loses only its frames (frame_ and digits .png, also those past the new
// count, which would otherwise pass as part of the sequence); the user's other files stay.
void FrameSink::move_frames_into_place() {
    std::error_code ec;
    const auto fail = [&](const std::error_code& e) {
        throw Error(str(path_, ": cannot move the frames into place (", e.message(), ")"));
    };
    if (!fs::is_directory(path_, ec)) {
        if (fs::exists(fs::symlink_status(path_, ec))) fs::remove(path_, ec);  // a file: replaced
        fs::rename(folder_, path_, ec);
        if (ec) fail(ec);
        return;
    }
    const auto is_frame = [](const fs::path& p) {
        const std::string name = p.filename().string();
        if (!name.starts_with("frame_") || !name.ends_with(".png") || name.size() < 15)
            return false;
        return std::all_of(name.begin() + 6, name.end() - 4,
                           [](char c) { return c >= '0' && c <= '9'; });
    };
    std::vector<fs::path> stale;
    for (const fs::directory_entry& e : fs::directory_iterator(path_, ec)) {
        if (is_frame(e.path()) && !e.is_directory()) stale.push_back(e.path());
    }
    if (ec) fail(ec);
    for (const fs::path& p : stale) {
        fs::remove(p, ec);
        if (ec) fail(ec);  // a stale frame left would pass as part of the new sequence
    }
    for (int64_t k = 0; k < frames_; ++k) {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%05lld.png", static_cast<long long>(k));
        fs::rename(fs::path(folder_) / name, fs::path(path_) / name, ec);
        if (ec) fail(ec);
    }
    fs::remove_all(folder_, ec);
}

}  // namespace tesswave::cli
