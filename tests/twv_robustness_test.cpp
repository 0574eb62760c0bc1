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
#include "core/math/strings.h"
#include "robustness.h"
#include "samples/sample_clip.h"
#include "temp_dir.h"
#include "video/dec_video.h"
#include "video/enc_video.h"
#include "video/twv_format.h"

namespace tesswave::video {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<uint8_t>;

std::string temp_path(const std::string& name) {
    static const testing::TempDir dir("twv_test");
    return dir / name;
}

Bytes read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return Bytes(std::istreambuf_iterator<char>(in), {});
}

void write_bytes(const std::string& path, const Bytes& b) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
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

// A file of a header (32x24 frames unless given) and the given chunks (valid CRCs), without an
// index.
std::string crafted(const std::vector<Bytes>& chunks,
                    const TwvHeader& header = {.width = 32, .height = 24}) {
    Bytes file = write_twv_header(header);
    for (const Bytes& c : chunks) file.insert(file.end(), c.begin(), c.end());
    const std::string path = temp_path("crafted.twv");
    write_bytes(path, file);
    return path;
}

Bytes group_chunk(TwvGroup g) { return twv_chunk('G', write_twv_group(g)); }

// A fixed-grid 5/3 group of `levels` for `header`'s frames, and its intra frame with no planes.
TwvGroup grid_group(const TwvHeader& header, int levels) {
    TwvGroup g{.transform = TwiTransform::grid53, .levels = levels, .channel_factors = {1, 1, 1}};
    g.band_norms.assign(twv_band_count(g, header), 1.0f);
    return g;
}

TwvFrame empty_intra(const TwvGroup& g) {
    TwvFrame intra{.number = 0, .kind = TwvFrameKind::intra};
    intra.planes.assign(3, std::vector<uint8_t>(g.band_norms.size(), 0));
    return intra;
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

// The reliability issue's .twv probes: a 123-byte file of 8192x8192 frames made `info` use
// 12 GiB (it decoded every frame) and `decode` run for minutes. The header's frame size is now
// weighed against the file's bytes (trusting limits let it through), and describing a file reads
// chunks without decoding them.
TEST(TwvRobustness, ASmallFileClaimsNoMoreThanItsBytesJustify) {
    const TwvHeader header{.width = 8192, .height = 8192};
    const TwvGroup g = grid_group(header, 5);
    const TwvFrame intra = empty_intra(g);
    Bytes file = write_twv_header(header);
    for (const Bytes& c : {group_chunk(g), twv_chunk('F', write_twv_frame(intra, g))}) {
        file.insert(file.end(), c.begin(), c.end());
    }
    EXPECT_LT(file.size(), 200u);
    const std::string path = temp_path("huge.twv");
    write_bytes(path, file);
    try {
        VideoDecoder decoder(path);
        ADD_FAILURE() << "a " << file.size() << "-byte file of 8192x8192 frames was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("-byte file"), std::string::npos) << e.what();
    }
    VideoDecoder trusting(path, {.free_pixels = int64_t{1} << 26});
    EXPECT_TRUE(trusting.skim());  // described without allocating a frame
    EXPECT_EQ(trusting.info().kind, TwvFrameKind::intra);
    EXPECT_FALSE(trusting.skim());
    Image frame;
    EXPECT_THROW(trusting.read(frame), Error);  // a skimming decoder does not decode
    fs::remove(path);
}

// The reliability issue's decode-work probe: 1024x1024 frames are within what any file may claim,
// but a few bytes make a frame, so a small file of many empty frames made the decoder work for
// minutes. The frames decoded are now weighed against the file's bytes (work counted, not time).
// Decodes the file at `path` (frames of `header`'s size) and expects it to stop, with the limit's
// message, after the frames its size allows (fewer than 100). Returns that count.
int64_t expect_decoding_stops_at_the_allowed_work(const std::string& path,
                                                  const TwvHeader& header) {
    const int64_t allowed = twv_work_allowed(static_cast<int64_t>(fs::file_size(path))) /
                            twv_frame_work(int64_t{header.width} * header.height);
    EXPECT_LT(allowed, 100);
    VideoDecoder decoder(path);
    Image skipped;
    int64_t frames = 0;
    while (frames <= allowed && decoder.read(skipped, false)) ++frames;
    EXPECT_EQ(frames, allowed);
    EXPECT_NE(decoder.damage().find("frame pixels that a"), std::string::npos) << decoder.damage();
    return allowed;
}

TEST(TwvRobustness, DecodingWorkIsBoundedByTheFileSize) {
    const TwvHeader header{.width = 1024, .height = 1024};
    const TwvGroup g = grid_group(header, 5);
    TwvFrame frame = empty_intra(g);
    std::vector<Bytes> chunks{group_chunk(g)};
    for (int t = 0; t < 1000; ++t) {
        frame.number = t;
        frame.kind = t == 0 ? TwvFrameKind::intra : TwvFrameKind::delta;
        chunks.push_back(twv_chunk('F', write_twv_frame(frame, g)));
    }
    const std::string path = crafted(chunks, header);
    EXPECT_LT(fs::file_size(path), 20'000u);
    const int64_t allowed = expect_decoding_stops_at_the_allowed_work(path, header);
    // Limits that trust the file (--max-pixels) decode on.
    VideoDecoder trusting(path, {.free_work_pixels = std::numeric_limits<int64_t>::max()});
    EXPECT_TRUE(trusting.seek(allowed + 10));
    fs::remove(path);
}

// A repeat count is charged as the frames it shows are: a tiny file shows no million frames.
TEST(TwvRobustness, RepeatsAreChargedAsTheFramesTheyShow) {
    const TwvHeader header{.width = 512, .height = 512};
    const TwvGroup g = grid_group(header, 5);
    TwvFrame frame = empty_intra(g);
    frame.repeats = kMaxRepeats;
    const std::string path =
        crafted({group_chunk(g), twv_chunk('F', write_twv_frame(frame, g))}, header);
    expect_decoding_stops_at_the_allowed_work(path, header);
    fs::remove(path);
}

// A lifted group is held whole: its coefficients are weighed against the file's bytes too.
TEST(TwvRobustness, ALiftedGroupsMemoryIsBoundedByTheFileSize) {
    for (const int side : {512, 700}) {
        const TwvHeader header{.width = side, .height = side};
        TwvGroup g = grid_group(header, 5);
        g.lifted = 16;
        TwvFrame band = empty_intra(g);
        std::vector<Bytes> chunks{group_chunk(g)};
        for (int t = 0; t < g.lifted; ++t) {
            band.number = t;
            band.kind = TwvFrameKind::band;
            chunks.push_back(twv_chunk('F', write_twv_frame(band, g)));
        }
        const std::string path = crafted(chunks, header);
        const int64_t size = static_cast<int64_t>(fs::file_size(path));
        const int64_t needs = twv_lifted_group_bytes(g, header);
        const bool fits = needs <= twv_group_bytes_allowed(size);
        EXPECT_EQ(fits, side == 512) << needs << " bytes for a " << size << "-byte file";
        // The frame size is not what is tested here: limits that let 700x700 frames through.
        VideoDecoder decoder(path, {.free_pixels = int64_t{1} << 20});
        Image skipped;
        int64_t frames = 0;
        while (decoder.read(skipped, false)) ++frames;
        EXPECT_EQ(frames, fits ? g.lifted : 0) << side << ": " << decoder.damage();
        EXPECT_EQ(decoder.damage().find("bytes of coefficients") != std::string::npos, !fits)
            << decoder.damage();
        fs::remove(path);
    }
}

// A static grid-mesh group of cols x rows cells at level J for `header`'s frames.
TwvGroup static_mesh_group(const TwvHeader& header, int cols, int rows, int levels) {
    TwvGroup g = grid_group(header, 2);
    g.transform = TwiTransform::mesh;
    g.motion = TwvMotion::none;
    g.levels = levels;
    g.grid_cols = cols;
    g.grid_rows = rows;
    g.band_norms.assign(twv_band_count(g, header), 1.0f);
    return g;
}

// A group's mesh is weighed against the file's bytes as a still file's is: a 101-byte file whose
// group claimed 11.5 M samples (724x724 frames, within 20 samples a pixel) cost its decoder
// 1.9 GiB. Here a 2x2 grid at J = 8 (263169 samples, 512x512 frames) is refused in a file of
// about 100 bytes, naming the group and the file's size, by `info` (skimming) as by decoding;
// limits that trust the file (--max-pixels) let it through.
TEST(TwvRobustness, AMeshGroupsSamplesAreBoundedByTheFileSize) {
    const TwvHeader header{.width = 512, .height = 512};
    const TwvGroup g = static_mesh_group(header, 2, 2, 8);
    const std::string path =
        crafted({group_chunk(g), twv_chunk('F', write_twv_frame(empty_intra(g), g))}, header);
    const int64_t size = static_cast<int64_t>(fs::file_size(path));
    EXPECT_LT(size, 200);
    EXPECT_EQ(twv_group_samples(g), 513 * 513);
    EXPECT_LT(twv_samples_allowed(size), twv_group_samples(g));
    for (const bool skim : {false, true}) {
        VideoDecoder decoder(path);
        Image frame;
        EXPECT_FALSE(skim ? decoder.skim() : decoder.read(frame));
        EXPECT_NE(decoder.damage().find("its mesh has 263169 samples, more than the"),
                  std::string::npos)
            << decoder.damage();
        EXPECT_NE(decoder.damage().find(str(size, "-byte file")), std::string::npos);
    }
    VideoDecoder trusting(path, {.free_samples = int64_t{1} << 20});
    EXPECT_TRUE(trusting.skim()) << trusting.damage();
    fs::remove(path);
}

// The same probe as a bound on memory: a file of about 100 bytes whose group claims 6.2 M mesh
// samples (a 78x78 grid at J = 5 on 512x512 frames, within 20 samples a pixel and 2^20) is
// decoded in a child whose address space may grow by 100 MiB only. Before the samples were
// weighed, its domain (about 160 bytes a sample) ran out of that space.
TEST(TwvRobustness, ATinyFileClaimingAHugeMeshDecodesWithin100MiB) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "address-space limits do not work under AddressSanitizer";
#endif
    const TwvHeader header{.width = 512, .height = 512};
    const TwvGroup g = static_mesh_group(header, 78, 78, 5);
    EXPECT_EQ(twv_group_samples(g), 2497 * 2497);
    EXPECT_TRUE(twv_group_size_problem(g, header).empty());
    const std::string path =
        crafted({group_chunk(g), twv_chunk('F', write_twv_frame(empty_intra(g), g))}, header);
    EXPECT_LT(fs::file_size(path), 200u);
    tesswave::testing::expect_error_or_return_in_child([&] {
        tesswave::testing::cap_address_space(size_t{100} << 20);
        try {
            VideoDecoder decoder(path);
            Image frame;
            while (decoder.read(frame)) {
            }
            if (decoder.damage().find("its mesh has") == std::string::npos) std::_Exit(5);
        } catch (const std::bad_alloc&) {
            std::fprintf(stderr, "the decoder needed more than 100 MiB\n");
            std::_Exit(4);
        }
    });
    fs::remove(path);
}

// The encoder pads a file whose mesh has more samples than its bytes would let a decoder accept:
// two flat 256x256 frames at density 4 (263169 samples) code into a few hundred bytes.
TEST(TwvRobustness, TheEncoderPadsAFileTooSmallForItsMesh) {
    const std::string path = temp_path("dense.twv");
    Image flat = make_image(256, 256, 3, SampleFormat::f32);
    for (auto& plane : flat.planes) std::fill(plane.begin(), plane.end(), 0.5f);
    for (const bool low_delay : {false, true}) {  // lifted groups and low-delay ones
        SCOPED_TRACE(low_delay ? "low delay" : "lifted");
        VideoEncoder encoder(path, 256, 256, 25,
                             {.motion = TwvMotion::none,
                              .density = 4,
                              .low_delay = low_delay,
                              .kbps = low_delay ? 0.0 : 1.0,  // low delay: at the default quality
                              .grid_groups = false});
        for (int t = 0; t < 2; ++t) encoder.encode(flat);
        const int64_t bytes = encoder.finish();
        EXPECT_GT(encoder.padding(), 0);
        const int64_t samples = 513 * 513;
        EXPECT_GE(twv_samples_allowed(bytes), samples);
        EXPECT_LT(twv_samples_allowed(bytes - 1), samples);
        VideoDecoder decoder(path);
        Image frame;
        int frames = 0;
        while (decoder.read(frame)) ++frames;
        EXPECT_EQ(frames, 2) << decoder.damage();
        EXPECT_TRUE(decoder.damage().empty()) << decoder.damage();
    }
    fs::remove(path);
}

// The encoder never writes a file its decoder would stop on: 64 flat 512x512 frames (16.8 M
// frame pixels) code into a few hundred bytes, more work than such a file may cost, so the
// encoder adds the fewest bytes of padding that let the decoder grant it; every frame then
// decodes within the default limits. One byte less and the decoder would stop: the bound is exact.
TEST(TwvRobustness, TheEncoderPadsAFileTooSmallForItsDecodingWork) {
    const std::string path = temp_path("flat.twv");
    Image flat = make_image(512, 512, 3, SampleFormat::f32);
    for (auto& plane : flat.planes) std::fill(plane.begin(), plane.end(), 0.5f);
    VideoEncoder encoder(path, 512, 512, 25,
                         {.transform = TwiTransform::grid53, .group = 8, .kbps = 1});
    for (int t = 0; t < 64; ++t) encoder.encode(flat);
    const int64_t bytes = encoder.finish();
    EXPECT_GT(encoder.padding(), 0);
    EXPECT_EQ(bytes, static_cast<int64_t>(fs::file_size(path)));
    EXPECT_GE(twv_work_allowed(bytes), 64 * 512 * 512);
    EXPECT_LT(twv_work_allowed(bytes - 1), 64 * 512 * 512);
    VideoDecoder decoder(path);
    Image frame;
    int frames = 0;
    while (decoder.read(frame)) ++frames;
    EXPECT_EQ(frames, 64) << decoder.damage();
    EXPECT_TRUE(decoder.damage().empty()) << decoder.damage();
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

// A short clip at a low rate is not refused for its group's memory: 24 textured 640x480 frames
// in one lifted group (88 MB of coefficients) at 8 kbit/s (about 1 KB) are written and decode.
TEST(TwvRobustness, AShortClipAtALowRateIsWrittenAndDecodes) {
    const std::string path = temp_path("short.twv");
    const samples::SampleClipOptions o{.width = 640, .height = 480, .frames = 24, .pan = {2, 1}};
    VideoEncoder encoder(path, o.width, o.height, 25,
                         {.transform = TwiTransform::grid53, .group = 24, .kbps = 8});
    for (int t = 0; t < o.frames; ++t) encoder.encode(samples::sample_clip_frame(o, t));
    ASSERT_NO_THROW(encoder.finish());
    VideoDecoder decoder(path);
    Image frame;
    int frames = 0;
    while (decoder.read(frame, false)) ++frames;
    EXPECT_EQ(frames, o.frames) << decoder.damage();
    EXPECT_TRUE(decoder.damage().empty()) << decoder.damage();
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

// The encoder refuses what the decoder refuses: J = 11 on 64x48 frames is over 20 samples a
// pixel (it used to write a file that decode refused; J = 12 took 32 s and 4.9 GiB a frame).
TEST(TwvRobustness, TheEncoderRefusesMeshesTheDecoderRefuses) {
    const std::string path = temp_path("levels.twv");
    EXPECT_THROW(VideoEncoder(path, 64, 48, 25, {.levels = 11}), Error);
    EXPECT_THROW(VideoEncoder(path, 64, 48, 25, {.levels = 12}), Error);
    EXPECT_NO_THROW(VideoEncoder(path, 64, 48, 25, {.levels = 4}));
    EXPECT_FALSE(fs::exists(path));
}

}  // namespace
}  // namespace tesswave::video
