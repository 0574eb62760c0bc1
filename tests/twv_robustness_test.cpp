// Damaged .twv files: every cut decodes the whole frames before it, every flipped byte decodes or
// stops with a message (never a crash, a hang or an unbounded allocation), and crafted chunks
// with valid CRCs but impossible contents are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>

#include "core/codec/byte_io.h"
#include "core/math/error.h"
#include "core/math/metrics.h"
#include "samples/sample_clip.h"
#include "temp_dir.h"
#include "twv_crafting.h"
#include "video/dec_video.h"
#include "video/enc_video.h"
#include "video/twv_format.h"

namespace tesswave::video {
namespace {

namespace fs = std::filesystem;

std::string temp_path(const std::string& name) {
    static const testing::TempDir dir("twv_test");
    return dir / name;
}

// A small clip: 48x32, 5 frames, tracked mesh, a new group at frame 3, about 1.3 kB; lifted
// groups or low-delay ones.
Bytes small_file(const std::string& path, bool low_delay) {
    const samples::SampleClipOptions o{.width = 48, .height = 32, .frames = 5, .pan = {1, 0.5}};
    VideoEncoder encoder(path, o.width, o.height, 25,
                         {.group = 3, .low_delay = low_delay, .kbps = 40});
    for (int t = 0; t < o.frames; ++t) encoder.encode(samples::sample_clip_frame(o, t));
    encoder.finish();
    return read_bytes(path);
}

struct Decoded {
    std::vector<Image> frames;
    std::string damage;
};

// Decodes what it can; an Error from the constructor (a damaged file header) gives no frames.
// With `bytes`, the decoder reads them from memory (named `path` in its messages).
Decoded decode(const std::string& path, const Bytes* bytes = nullptr) {
    Decoded out;
    try {
        VideoDecoder decoder =
            bytes ? VideoDecoder(memory_source(*bytes), path) : VideoDecoder(path);
        Image frame;
        while (decoder.read(frame)) out.frames.push_back(frame);
        out.damage = decoder.damage();
    } catch (const Error& e) {
        out.damage = e.what();
    }
    return out;
}

// The end offset of every frame chunk, from the file's own index; `boundaries` gets every
// offset where a cut leaves whole chunks only, `group_ends` per frame the end of its group's last
// frame chunk.
std::vector<uint64_t> frame_ends(const Bytes& file, std::vector<uint64_t>* boundaries = nullptr,
                                 std::vector<uint64_t>* group_ends = nullptr) {
    uint64_t index_offset = 0;
    for (int i = 7; i >= 0; --i) index_offset = (index_offset << 8) | file[file.size() - 12 + i];
    ByteReader r(std::span<const uint8_t>(file).subspan(index_offset), "index");
    r.u8("tag");
    const auto size = r.varint("size");
    const TwvIndex index = read_twv_index(r.bytes(size, "payload"), index_offset, "index", {}, 5);
    std::vector<uint64_t> starts = index.frame_offsets;
    starts.insert(starts.end(), index.group_offsets.begin(), index.group_offsets.end());
    starts.push_back(index_offset);
    std::sort(starts.begin(), starts.end());
    if (boundaries) *boundaries = starts;
    std::vector<uint64_t> ends;
    for (uint64_t f : index.frame_offsets)
        ends.push_back(*std::upper_bound(starts.begin(), starts.end(), f));
    if (group_ends) {
        group_ends->assign(ends.size(), 0);
        for (size_t t = 0; t < ends.size(); ++t) {
            const auto next = std::upper_bound(index.group_first.begin(), index.group_first.end(),
                                               static_cast<int64_t>(t));
            const size_t last =
                next == index.group_first.end() ? ends.size() - 1 : static_cast<size_t>(*next) - 1;
            (*group_ends)[t] = ends[last];
        }
    }
    return ends;
}

// Low delay: every whole frame chunk decodes exactly. Lifted: every frame whose chunk arrived is
// decoded, exactly once its whole group arrived (else from the bands received), and a cut inside
// a group is reported.
TEST(TwvRobustness, EveryCutDecodesTheWholeFramesBeforeIt) {
    for (bool low_delay : {true, false}) {
        SCOPED_TRACE(low_delay ? "low delay" : "lifted");
        const std::string path = temp_path("cut_source.twv"), cut = temp_path("cut.twv");
        const Bytes file = small_file(path, low_delay);
        const Decoded full = decode(path);
        ASSERT_EQ(full.frames.size(), 5u);
        ASSERT_EQ(full.damage, "");
        std::vector<uint64_t> boundaries, group_ends;
        const std::vector<uint64_t> ends = frame_ends(file, &boundaries, &group_ends);
        boundaries.push_back(write_twv_header({}).size());  // a header alone: no frames
        EXPECT_LT(file.size(), 2000u);
        for (size_t n = 0; n < file.size(); ++n) {
            write_bytes(cut, Bytes(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(n)));
            const Decoded d = decode(cut);
            const size_t whole = static_cast<size_t>(
                std::count_if(ends.begin(), ends.end(), [&](uint64_t e) { return e <= n; }));
            ASSERT_EQ(d.frames.size(), whole) << "cut at " << n << ": " << d.damage;
            bool inside_group = false;
            for (size_t t = 0; t < whole; ++t) {
                if (low_delay || group_ends[t] <= n) {
                    ASSERT_EQ(d.frames[t].planes, full.frames[t].planes) << "cut at " << n;
                } else {
                    inside_group = true;
                    ASSERT_EQ(d.frames[t].width, 48);
                    ASSERT_GT(psnr(full.frames[t], d.frames[t]).all, 10) << "cut at " << n;
                }
            }
            // Whole chunks only (and no group cut short), or a whole index with a cut trailer.
            const bool clean =
                (std::find(boundaries.begin(), boundaries.end(), n) != boundaries.end() &&
                 !inside_group) ||
                n >= file.size() - kTwvTrailerBytes;
            EXPECT_EQ(d.damage.empty(), clean) << "cut at " << n << ": " << d.damage;
        }
        fs::remove(path);
        fs::remove(cut);
    }
}

// The decoder reads a file and bytes in memory alike, cut anywhere: same frames, same messages.
TEST(TwvRobustness, BytesInMemoryDecodeAsTheFileDoes) {
    const std::string path = temp_path("memory_source.twv"), cut = temp_path("memory_cut.twv");
    const Bytes file = small_file(path, false);
    for (size_t n = 0; n <= file.size(); n += 7) {
        const Bytes prefix(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(n));
        write_bytes(cut, prefix);
        const Decoded from_file = decode(cut), from_memory = decode(cut, &prefix);
        ASSERT_EQ(from_memory.damage, from_file.damage) << "cut at " << n;
        ASSERT_EQ(from_memory.frames.size(), from_file.frames.size()) << "cut at " << n;
        for (size_t t = 0; t < from_file.frames.size(); ++t) {
            ASSERT_EQ(from_memory.frames[t].planes, from_file.frames[t].planes) << "cut at " << n;
        }
    }
}

TEST(TwvRobustness, EveryFlippedByteDecodesOrStopsWithAMessage) {
    for (bool low_delay : {true, false}) {
        SCOPED_TRACE(low_delay ? "low delay" : "lifted");
        const std::string path = temp_path("flip_source.twv"), flipped = temp_path("flip.twv");
        const Bytes file = small_file(path, low_delay);
        const Decoded full = decode(path);
        std::vector<uint64_t> group_ends;
        const std::vector<uint64_t> ends = frame_ends(file, nullptr, &group_ends);
        int stopped = 0, complete = 0;
        for (size_t i = 0; i < file.size(); ++i) {
            for (uint8_t mask : {uint8_t{0xFF}, uint8_t{0x10}}) {
                Bytes b = file;
                b[i] ^= mask;
                write_bytes(flipped, b);
                const Decoded d = decode(flipped);
                // Frames before the damaged chunk (lifted: in groups before it) are decoded
                // exactly; a flip in the index or the trailer only costs the index.
                ASSERT_LE(d.frames.size(), full.frames.size());
                for (size_t t = 0; t < d.frames.size(); ++t) {
                    if (low_delay || group_ends[t] <= i) {
                        ASSERT_EQ(d.frames[t].planes, full.frames[t].planes) << "byte " << i;
                    }
                }
                const size_t before = static_cast<size_t>(
                    std::count_if(ends.begin(), ends.end(), [&](uint64_t e) { return e <= i; }));
                EXPECT_GE(d.frames.size(), std::min(before, full.frames.size())) << "byte " << i;
                (d.damage.empty() ? complete : stopped)++;
            }
        }
        EXPECT_GT(stopped, 0);
        EXPECT_GT(complete, 0);  // index and trailer flips
        fs::remove(path);
        fs::remove(flipped);
    }
}

TEST(TwvRobustness, ForeignAndEmptyFilesAreRefused) {
    const std::string path = temp_path("foreign.twv");
    for (const Bytes& b :
         {Bytes{}, Bytes{'T', 'W', 'V'}, Bytes{'T', 'W', 'I', 0x1A, 1, 2, 3}, Bytes(1000, 0x5A)}) {
        write_bytes(path, b);
        EXPECT_THROW(VideoDecoder{path}, Error);
    }
    EXPECT_THROW(VideoDecoder{temp_path("missing.twv")}, Error);
    fs::remove(path);
}

TEST(TwvRobustness, CraftedChunksWithValidCrcsAreRefused) {
    const TwvHeader header{.width = 32, .height = 24};
    const TwvGroup g = grid_group(header, 2);
    const TwvFrame intra = empty_intra(g);
    TwvFrame delta = intra;
    delta.kind = TwvFrameKind::delta;
    const Bytes frame0 = twv_chunk('F', write_twv_frame(intra, g));
    delta.number = 1;
    const Bytes frame1 = twv_chunk('F', write_twv_frame(delta, g));
    struct Case {
        const char* what;
        std::vector<Bytes> chunks;
        size_t frames;
    };
    TwvGroup huge = g;
    huge.transform = TwiTransform::mesh;
    huge.levels = 12;
    huge.grid_cols = 32;
    huge.grid_rows = 24;
    huge.band_norms.assign(25, 1.0f);
    TwvGroup late = g;
    late.first_frame = 7;
    Bytes oversized{'F'};
    for (int i = 0; i < 5; ++i) oversized.push_back(0xFF);
    oversized.push_back(0x0F);
    const Case cases[] = {
        {"a sound clip", {group_chunk(g), frame0, frame1}, 2},
        {"a frame before any group", {frame0}, 0},
        {"a delta frame first", {group_chunk(g), frame1}, 0},
        {"a frame number out of order", {group_chunk(g), frame1, frame0}, 0},
        {"a second intra frame inside a group", {group_chunk(g), frame0, frame0}, 1},
        {"a group at the wrong frame", {group_chunk(late), frame0}, 0},
        {"a mesh over the sample limit", {group_chunk(huge), frame0}, 0},
        {"a chunk claiming 2^40 bytes", {group_chunk(g), frame0, oversized}, 1},
        {"an unknown chunk", {group_chunk(g), frame0, twv_chunk('Q', Bytes{1, 2})}, 1},
    };
    for (const Case& c : cases) {
        const Decoded d = decode(crafted(c.chunks));
        EXPECT_EQ(d.frames.size(), c.frames) << c.what;
        EXPECT_EQ(d.damage.empty(), c.frames == 2) << c.what << ": " << d.damage;
    }
    fs::remove(temp_path("crafted.twv"));
}

// Two groups that differ only in their canvas do not share a coding domain: a crafted second
// group with the first one's grid and norms but a wider canvas decodes as it does alone (read
// straight through, the decoder once kept the first group's narrower canvas for it).
TEST(TwvRobustness, AGroupOnAnotherCanvasGetsItsOwnDomain) {
    // Two scenes of 8 frames, panning 0.5 and 1.5 pixels a frame: canvases 8 and 16 pixels wider.
    samples::SampleClipOptions a{.width = 176, .height = 144, .frames = 8, .pan = {0.5, 0}};
    samples::SampleClipOptions b = a;
    b.pan = {1.5, 0};
    b.seed = 2;
    const std::string path = temp_path("two_canvases.twv");
    {
        VideoEncoder encoder(path, a.width, a.height, 25,
                             {.group = 8, .kbps = 200, .grid_groups = false});
        for (int t = 0; t < 8; ++t) encoder.encode(samples::sample_clip_frame(a, t));
        for (int t = 0; t < 8; ++t) encoder.encode(samples::sample_clip_frame(b, t));
        encoder.finish();
    }
    Bytes file = read_bytes(path);
    size_t at = 0;
    const TwvHeader header = read_twv_header(file, path, at);
    std::vector<std::pair<size_t, TwvGroup>> groups;  // chunk offset, group
    while (at + kTwvTrailerBytes < file.size()) {
        ByteReader r(std::span<const uint8_t>(file).subspan(at), "chunk");
        const uint32_t tag = r.u8("tag");
        const auto size = r.varint("size");
        const auto payload = r.bytes(size, "payload");
        if (tag == 'G') groups.emplace_back(at, read_twv_group(payload, header, "group"));
        at += r.position() + 4;
        if (tag == 'I') break;
    }
    ASSERT_EQ(groups.size(), 2u);
    const TwvGroup& first = groups[0].second;
    TwvGroup second = groups[1].second;
    ASSERT_TRUE(first.has_canvas() && second.has_canvas());
    ASSERT_LT(first.extend_x, second.extend_x);
    // The second group as the first in all but its canvas (its own norms taken away).
    ASSERT_EQ(first.grid_cols, second.grid_cols);
    ASSERT_EQ(first.grid_rows, second.grid_rows);
    second.band_norms = first.band_norms;
    const Bytes chunk = twv_chunk('G', write_twv_group(second));
    ByteReader old(std::span<const uint8_t>(file).subspan(groups[1].first), "chunk");
    old.u8("tag");
    const auto old_payload = old.varint("size");
    ASSERT_EQ(chunk.size(), old.position() + old_payload + 4);  // the file's offsets hold
    std::copy(chunk.begin(), chunk.end(),
              file.begin() + static_cast<std::ptrdiff_t>(groups[1].first));
    write_bytes(path, file);

    VideoDecoder through(path);
    VideoDecoder alone(path);
    ASSERT_TRUE(alone.seek(8)) << alone.damage();
    Image frame, expected;
    for (int t = 0; t < 8; ++t) ASSERT_TRUE(through.read(frame)) << through.damage();
    for (int t = 8; t < 16; ++t) {
        ASSERT_TRUE(through.read(frame)) << t << ": " << through.damage();
        ASSERT_TRUE(alone.read(expected)) << t << ": " << alone.damage();
        EXPECT_EQ(frame.planes, expected.planes) << t;
    }
    fs::remove(path);
}

// Padding chunks make up exactly the bytes asked for (from a chunk's least size, 6, on), with
// payloads of at most `most`; a decoder skips them, between the last frame and the index, with
// the index or scanning without it, and decodes the same frames.
TEST(TwvRobustness, PaddingChunksAreSkipped) {
    for (int64_t bytes : {1, 5, 6, 7, 70, 300}) {
        int64_t total = 0;
        for (const Bytes& chunk : twv_padding(bytes, 64)) {
            ASSERT_GE(chunk.size(), 6u);
            EXPECT_EQ(chunk[0], 'P');
            EXPECT_LE(chunk.size(), 64u + 6u);
            total += static_cast<int64_t>(chunk.size());
        }
        EXPECT_EQ(total, std::max<int64_t>(bytes, 6)) << bytes;
    }
    const std::string path = temp_path("padded.twv");
    const Bytes file = small_file(path, false);
    const Decoded plain = decode(path);
    ASSERT_EQ(plain.frames.size(), 5u) << plain.damage;
    uint64_t index_offset = 0;
    for (int i = 7; i >= 0; --i) index_offset = (index_offset << 8) | file[file.size() - 12 + i];
    Bytes padded(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(index_offset));
    for (const Bytes& chunk : twv_padding(300, 64))
        padded.insert(padded.end(), chunk.begin(), chunk.end());
    const uint64_t moved = padded.size();
    padded.insert(padded.end(), file.begin() + static_cast<std::ptrdiff_t>(index_offset),
                  file.end() - kTwvTrailerBytes);
    const Bytes trailer = twv_trailer(moved);
    padded.insert(padded.end(), trailer.begin(), trailer.end());
    const Bytes scanned(padded.begin(), padded.end() - kTwvTrailerBytes);  // no trailer: a scan
    for (const Bytes* bytes : std::initializer_list<const Bytes*>{&padded, &scanned}) {
        const Decoded d = decode(path, bytes);
        ASSERT_EQ(d.frames.size(), plain.frames.size()) << d.damage;
        EXPECT_EQ(d.damage, plain.damage);
        for (size_t t = 0; t < d.frames.size(); ++t)
            EXPECT_EQ(d.frames[t].planes, plain.frames[t].planes);
    }
    fs::remove(path);
}

TEST(TwvRobustness, SkimmingSeesTheFramesThatDecodingSees) {
    const std::string path = temp_path("skim.twv");
    for (bool low_delay : {true, false}) {
        small_file(path, low_delay);
        VideoDecoder decoding(path), skimming(path);
        Image frame;
        int frames = 0;
        while (decoding.read(frame, false)) {
            ASSERT_TRUE(skimming.skim());
            EXPECT_EQ(skimming.info().number, decoding.info().number);
            EXPECT_EQ(skimming.info().kind, decoding.info().kind);
            EXPECT_EQ(skimming.info().bytes, decoding.info().bytes);
            EXPECT_EQ(skimming.info().motion_bytes, decoding.info().motion_bytes);
            ++frames;
        }
        EXPECT_FALSE(skimming.skim());
        EXPECT_EQ(frames, 5);
    }
    fs::remove(path);
}

}  // namespace
}  // namespace tesswave::video
