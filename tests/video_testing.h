// Helpers of the .twv codec tests: code a clip and keep what the encoder gives back, decode a
// file, compare images bit for bit, and the sample pans the tests code.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "samples/sample_clip.h"
#include "temp_dir.h"
#include "video/dec_video.h"
#include "video/enc_video.h"

namespace tesswave::video::testing_video {

struct Coded {
    std::vector<Image> reconstructions;
    std::vector<EncodedFrame> frames;
    std::vector<std::vector<Vec2>> vertices;
    int64_t bytes = 0;
};

inline std::string temp_path(const std::string& name) {
    static const testing::TempDir dir("video_test");
    return dir / name;
}

inline std::vector<Image> clip(const samples::SampleClipOptions& o) {
    std::vector<Image> frames;
    for (int t = 0; t < o.frames; ++t) frames.push_back(samples::sample_clip_frame(o, t));
    return frames;
}

inline Coded encode(const std::vector<Image>& frames, const std::string& path,
                    const VideoEncodeOptions& options) {
    VideoEncoder encoder(path, frames[0].width, frames[0].height, 25, options);
    Coded out;
    const auto take = [&](std::vector<EncodedFrame> done) {
        for (EncodedFrame& f : done) {
            out.reconstructions.push_back(std::move(f.reconstruction));
            out.vertices.push_back(f.vertices);
            out.frames.push_back(std::move(f));
        }
    };
    for (const Image& f : frames) take(encoder.encode(f));
    take(encoder.flush());
    out.bytes = encoder.finish();
    return out;
}

inline std::vector<Image> decode_all(const std::string& path, std::string* damage = nullptr) {
    VideoDecoder decoder(path);
    std::vector<Image> out;
    Image frame;
    while (decoder.read(frame)) out.push_back(frame);
    if (damage) *damage = decoder.damage();
    return out;
}

inline void expect_identical(const Image& a, const Image& b) {
    ASSERT_EQ(a.width, b.width);
    ASSERT_EQ(a.height, b.height);
    ASSERT_EQ(a.planes, b.planes);  // every float, bit for bit
}

inline double mean_psnr(const Coded& c) {
    double sum = 0;
    for (const EncodedFrame& f : c.frames) sum += f.psnr;
    return sum / static_cast<double>(c.frames.size());
}

inline samples::SampleClipOptions small_pan() {
    return {.width = 64, .height = 48, .frames = 6, .pan = {1.25, 0.5}, .object = true};
}

// A slower pan with the moving disk, for the lifted groups' rate and quality tests.
inline samples::SampleClipOptions slow_pan(int frames) {
    return {.width = 96, .height = 64, .frames = frames, .pan = {0.75, 0.25}, .object = true};
}

}  // namespace tesswave::video::testing_video
