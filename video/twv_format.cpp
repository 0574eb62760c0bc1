#include "twv_format.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/codec/byte_io.h"
#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave::video {
namespace {

constexpr uint32_t kVersion = 6;
constexpr uint8_t kRepeatsFollow = 0x80;  // in a frame's kind byte (version 5)

void write_u64(ByteWriter& w, uint64_t v) {
    for (int i = 0; i < 8; ++i) w.u8(static_cast<uint8_t>(v >> (8 * i)));
}

// Samples of T_J on a cols x rows grid: (cols 2^J + 1)(rows 2^J + 1), in double (no overflow for
// any header values the reader lets through).
double grid_samples(int cols, int rows, int levels) {
    const double cell = std::ldexp(1.0, levels);
    return (cols * cell + 1) * (rows * cell + 1);
}

}  // namespace

int64_t twv_bytes_needed(int64_t pixels, const TwvLimits& limits) {
    if (pixels <= limits.free_pixels) return 0;
    return (pixels - limits.free_pixels + limits.pixels_per_byte - 1) /
           std::max<int64_t>(limits.pixels_per_byte, 1);
}

namespace {

// free + bytes * per_byte, saturating at the largest int64_t.
int64_t weighed(int64_t free, int64_t per_byte, int64_t bytes) {
    constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
    if (per_byte > 0 && bytes > (kMax - free) / per_byte) return kMax;
    return free + bytes * per_byte;
}

}  // namespace

int64_t twv_work_allowed(int64_t file_bytes, const TwvLimits& limits) {
    return weighed(limits.free_work_pixels, limits.work_pixels_per_byte, file_bytes);
}

int64_t twv_group_bytes_allowed(int64_t file_bytes, const TwvLimits& limits) {
    return std::min(limits.max_group_bytes,
                    weighed(limits.free_group_bytes, limits.group_bytes_per_byte, file_bytes));
}

int64_t twv_samples_allowed(int64_t file_bytes, const TwvLimits& limits) {
    return weighed(limits.free_samples, limits.samples_per_byte, file_bytes);
}

int64_t twv_file_bytes_needed(int64_t pixels, int64_t frames, int64_t group_bytes, int64_t samples,
                              const TwvLimits& limits) {
    constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
    if (group_bytes > limits.max_group_bytes) return kMax;
    // The fewest bytes b with free + b per_byte >= need.
    auto fewest = [&](int64_t need, int64_t free, int64_t per_byte) -> int64_t {
        if (need <= free) return 0;
        if (per_byte <= 0) return kMax;
        return (need - free + per_byte - 1) / per_byte;
    };
    const int64_t frame = twv_frame_work(pixels);
    const int64_t work = frames > 0 && frame > kMax / frames ? kMax : frames * frame;
    return std::max({twv_bytes_needed(pixels, limits),
                     fewest(work, limits.free_work_pixels, limits.work_pixels_per_byte),
                     fewest(group_bytes, limits.free_group_bytes, limits.group_bytes_per_byte),
                     fewest(samples, limits.free_samples, limits.samples_per_byte)});
}

std::vector<uint8_t> write_twv_header(const TwvHeader& h) {
    ByteWriter w;
    for (uint8_t b : kTwvMagic) w.u8(b);
    w.u8(kVersion);
    w.varint(h.width);
    w.varint(h.height);
    w.varint(h.fps_num);
    w.varint(h.fps_den);
    w.u8(h.channels);
    w.u8(h.bit_depth);
    w.u32(crc32(w.data()));
    return std::move(w.data());
}

TwvHeader read_twv_header(std::span<const uint8_t> file, const std::string& name, size_t& used,
                          const TwvLimits& limits) {
    ByteReader r(file, name);
    for (uint8_t b : kTwvMagic) {
        if (r.remaining() == 0) r.fail("truncated: not even a file header");
        if (r.u8("magic") != b) r.fail("not a .twv file (bad magic)");
    }
    const uint32_t version = r.u8("version");
    if (version < 1 || version > kVersion) r.fail(str("unsupported .twv version ", version));
    TwvHeader h;
    h.version = static_cast<int>(version);
    h.width = static_cast<int>(r.count("width", 1, 16384));
    h.height = static_cast<int>(r.count("height", 1, 16384));
    h.fps_num = static_cast<int>(r.count("fps numerator", 1, 1'000'000));
    h.fps_den = static_cast<int>(r.count("fps denominator", 1, 1'000'000));
    h.channels = static_cast<int>(r.u8("channels"));
    h.bit_depth = static_cast<int>(r.u8("bit depth"));
    const size_t covered = r.position();
    const uint32_t crc = r.u32("header CRC");
    if (crc != crc32(file.first(covered))) r.fail("damaged file header (CRC mismatch)");
    if (h.channels != 1 && h.channels != 3) r.fail(str("unsupported channel count ", h.channels));
    if (h.bit_depth != 8) r.fail(str("unsupported bit depth ", h.bit_depth));
    if (int64_t{h.width} * h.height > limits.max_pixels) {
        r.fail(str(h.width, "x", h.height, " pixels exceed the limit of ", limits.max_pixels));
    }
    if (h.fps() > 1000 || h.fps() < 1e-3) r.fail(str("frame rate ", h.fps(), " is out of range"));
    used = r.position();
    return h;
}

std::vector<uint8_t> twv_chunk(uint8_t tag, std::span<const uint8_t> payload) {
    ByteWriter w;
    w.u8(tag);
    w.varint(payload.size());
    w.bytes(payload);
    w.u32(crc32(w.data()));
    return std::move(w.data());
}

int twv_band_count(const TwvGroup& g, const TwvHeader& h) {
    return coding_band_count(g.transform, g.mesh_wavelet, g.levels, h.width, h.height);
}

std::vector<std::vector<uint8_t>> twv_padding(int64_t bytes, int64_t most) {
    // A chunk of n payload bytes takes the tag, n's varint, n and the CRC.
    auto chunk_bytes = [](int64_t n) {
        int64_t varint = 1;
        for (int64_t v = n; v >= 128; v >>= 7) ++varint;
        return 1 + varint + n + 4;
    };
    std::vector<std::vector<uint8_t>> chunks;
    for (int64_t rest = bytes; rest > 0;) {
        // The last chunk takes the smallest payload that makes up the rest.
        int64_t payload = std::clamp<int64_t>(rest, 0, std::max<int64_t>(most, 0));
        while (payload > 0 && chunk_bytes(payload - 1) >= rest) --payload;
        chunks.push_back(twv_chunk('P', std::vector<uint8_t>(static_cast<size_t>(payload))));
        rest -= static_cast<int64_t>(chunks.back().size());
    }
    return chunks;
}

std::vector<uint8_t> write_twv_group(const TwvGroup& g) {
    ByteWriter w;
    w.varint(g.first_frame);
    w.u8(static_cast<uint8_t>(g.transform));
    w.u8(g.levels);
    if (g.transform == TwiTransform::mesh) {
        w.u8(static_cast<uint8_t>(g.motion));
        w.varint(g.grid_cols);
        w.varint(g.grid_rows);
        w.u8(static_cast<uint8_t>(g.mesh_wavelet));
    }
    for (float f : g.channel_factors) w.f32(f);
    w.varint(g.band_norms.size());
    for (float n : g.band_norms) w.f32(n);
    w.varint(g.lifted);
    if (g.transform == TwiTransform::mesh && g.motion == TwvMotion::tracked) {
        w.varint(g.extend_x);
        w.varint(g.extend_y);
    }
    return std::move(w.data());
}

int64_t twv_frame_coefficient_bytes(const TwvGroup& g, const TwvHeader& h) {
    const double samples = g.transform == TwiTransform::mesh
                               ? grid_samples(g.grid_cols, g.grid_rows, g.levels)
                               : static_cast<double>(h.width) * h.height;
    return static_cast<int64_t>(samples) * h.channels * 4;
}

int64_t twv_group_samples(const TwvGroup& g) {
    if (g.transform != TwiTransform::mesh) return 0;
    return static_cast<int64_t>(grid_samples(g.grid_cols, g.grid_rows, g.levels));
}

int64_t twv_lifted_group_bytes(const TwvGroup& g, const TwvHeader& h) {
    return g.lifted * twv_frame_coefficient_bytes(g, h);
}

int twv_max_lifted_frames(const TwvGroup& g, const TwvHeader& h, const TwvLimits& limits) {
    const int64_t frame = std::max<int64_t>(twv_frame_coefficient_bytes(g, h), 1);
    return static_cast<int>(
        std::clamp<int64_t>(limits.max_group_bytes / frame, 1, limits.max_lifted_frames));
}

std::string twv_group_size_problem(const TwvGroup& g, const TwvHeader& h, const TwvLimits& limits) {
    if (g.lifted > 0 && g.lifted > twv_max_lifted_frames(g, h, limits)) {
        return str("a lifted group of ", g.lifted, " frames exceeds the limit of ",
                   twv_max_lifted_frames(g, h, limits), " (", limits.max_group_bytes,
                   " bytes of coefficients)");
    }
    if (g.transform != TwiTransform::mesh) return {};
    if (g.levels < 1 || g.levels > 12) return str("mesh level ", g.levels, " is outside 1..12");
    if (g.extend_x < 0 || g.extend_y < 0 || g.extend_x > h.width || g.extend_y > h.height) {
        return str("a canvas of ", h.width + g.extend_x, "x", h.height + g.extend_y,
                   " is more than twice the frame");
    }
    const double samples = grid_samples(g.grid_cols, g.grid_rows, g.levels);
    const double cap = limits.max_samples_per_pixel * h.width * h.height + (1 << 20);
    if (samples > static_cast<double>(limits.max_samples) || samples > cap) {
        return str("the mesh has ", samples, " samples at level ", g.levels, " (limit ",
                   limits.max_samples, ", and ", limits.max_samples_per_pixel, " a pixel)");
    }
    return {};
}

TwvGroup read_twv_group(std::span<const uint8_t> payload, const TwvHeader& h,
                        const std::string& what, const TwvLimits& limits) {
    ByteReader r(payload, what);
    TwvGroup g;
    g.first_frame = r.count("first frame", 0, limits.max_frames - 1);
    g.transform = static_cast<TwiTransform>(r.count("transform", 0, 2));
    if (g.transform == TwiTransform::mesh) {
        g.levels = static_cast<int>(r.count("levels", 1, 12));
        g.motion = static_cast<TwvMotion>(r.count("motion", 0, 1));
        // A canvas is at most twice the frame a side (its grid too).
        g.grid_cols = static_cast<int>(r.count("grid columns", 1, int64_t{2} * h.width));
        g.grid_rows = static_cast<int>(r.count("grid rows", 1, int64_t{2} * h.height));
        if (h.version >= 4)
            g.mesh_wavelet = static_cast<MeshWavelet>(r.count("mesh wavelet", 0, 1));
        const std::string problem = twv_group_size_problem(g, h, limits);
        if (!problem.empty()) r.fail(problem);
    } else {
        g.levels = static_cast<int>(r.count("levels", 0, 20));
    }
    for (int c = 0; c < h.channels; ++c) {
        const float f = r.f32("step factor");
        if (!(f > 0)) r.fail("step factors must be positive");
        g.channel_factors.push_back(f);
    }
    const int bands = twv_band_count(g, h);
    r.count("band count", bands, bands);
    for (int b = 0; b < bands; ++b) {
        const float n = r.f32("band norm");
        if (!(n > 0)) r.fail("band norms must be positive");
        g.band_norms.push_back(n);
    }
    if (h.version >= 2) {
        g.lifted = static_cast<int>(r.count("lifted frames", 0, limits.max_lifted_frames));
    }
    if (h.version >= 3 && g.transform == TwiTransform::mesh && g.motion == TwvMotion::tracked) {
        g.extend_x = static_cast<int>(r.count("canvas extension x", 0, h.width));
        g.extend_y = static_cast<int>(r.count("canvas extension y", 0, h.height));
        if (g.has_canvas() && g.lifted == 0) r.fail("a canvas in a low-delay group");
    }
    if (g.transform == TwiTransform::mesh &&
        (g.grid_cols > h.width + g.extend_x || g.grid_rows > h.height + g.extend_y)) {
        r.fail(str("a grid of ", g.grid_cols, "x", g.grid_rows, " cells on ", h.width + g.extend_x,
                   "x", h.height + g.extend_y, " pixels"));
    }
    if (h.version >= 2) {
        const std::string problem = twv_group_size_problem(g, h, limits);
        if (!problem.empty()) r.fail(problem);
    }
    if (r.remaining() != 0) r.fail(str(r.remaining(), " unexpected bytes after the group"));
    return g;
}

std::vector<uint8_t> write_twv_frame(const TwvFrame& f, const TwvGroup& g) {
    ByteWriter w;
    w.varint(f.number);
    // Version 5: the kind's top bit says that a repeat count follows.
    w.u8(static_cast<uint8_t>(static_cast<uint8_t>(f.kind) | (f.repeats > 0 ? kRepeatsFollow : 0)));
    if (f.repeats > 0) w.varint(static_cast<uint64_t>(f.repeats));
    w.f32(f.base_step);
    if (g.has_canvas()) {
        w.varint(static_cast<uint64_t>(f.window_x));
        w.varint(static_cast<uint64_t>(f.window_y));
    }
    if (g.transform == TwiTransform::mesh && g.motion == TwvMotion::tracked) {
        w.varint(f.motion.size());
        w.bytes(f.motion);
    }
    // The largest plane count first: 0 (a frame with nothing to add) ends the payload there.
    uint8_t top = 0;
    for (const auto& channel : f.planes)
        top = std::max(top, *std::max_element(channel.begin(), channel.end()));
    w.u8(top);
    if (top == 0) return std::move(w.data());
    // Version 2: with at most 15 planes, two counts a byte (low nibble first).
    std::vector<uint8_t> counts;
    for (const auto& channel : f.planes)
        counts.insert(counts.end(), channel.begin(), channel.end());
    if (top <= 15) {
        for (size_t i = 0; i < counts.size(); i += 2) {
            w.u8(
                static_cast<uint8_t>(counts[i] | (i + 1 < counts.size() ? counts[i + 1] << 4 : 0)));
        }
    } else {
        for (uint8_t p : counts) w.u8(p);
    }
    w.bytes(f.stream);
    return std::move(w.data());
}

TwvFrame read_twv_frame(std::span<const uint8_t> payload, const TwvGroup& g, const TwvHeader& h,
                        const std::string& what) {
    ByteReader r(payload, what);
    TwvFrame f;
    f.number = static_cast<int64_t>(r.varint("frame number"));
    uint32_t kind = r.u8("frame kind");
    if (h.version >= 5 && (kind & kRepeatsFollow)) {
        f.repeats = r.count("repeats", 1, kMaxRepeats);
        kind &= ~uint32_t{kRepeatsFollow};
    }
    if (kind > 2) r.fail(str("frame kind = ", kind, " is outside [0, 2]"));
    f.kind = static_cast<TwvFrameKind>(kind);
    if ((f.kind == TwvFrameKind::band) != (g.lifted > 0)) {
        r.fail(g.lifted > 0 ? "a lifted group holds temporal bands only"
                            : "a temporal band outside a lifted group");
    }
    f.base_step = r.f32("base step");
    if (!(f.base_step > 0)) r.fail("the base step must be positive");
    if (g.has_canvas()) {
        f.window_x = static_cast<int32_t>(r.count("window left", 0, int64_t{4} * g.extend_x));
        f.window_y = static_cast<int32_t>(r.count("window top", 0, int64_t{4} * g.extend_y));
    }
    if (g.transform == TwiTransform::mesh && g.motion == TwvMotion::tracked) {
        const int64_t n = r.count("motion bytes", 0, static_cast<int64_t>(r.remaining()));
        const auto bytes = r.bytes(static_cast<size_t>(n), "motion");
        f.motion.assign(bytes.begin(), bytes.end());
    }
    const int bands = static_cast<int>(g.band_norms.size());
    f.planes.assign(h.channels, std::vector<uint8_t>(bands, 0));
    const auto top = r.count("largest bit-plane count", 0, 31);
    if (top == 0) {
        if (r.remaining() != 0) r.fail("unexpected bytes after an empty frame");
        return f;
    }
    uint32_t largest = 0;
    const bool packed = h.version >= 2 && top <= 15;
    uint8_t pair = 0;
    size_t i = 0;
    for (auto& channel : f.planes) {
        for (uint8_t& p : channel) {
            if (!packed) {
                p = static_cast<uint8_t>(r.u8("bit-planes"));
            } else if (i++ % 2 == 0) {
                pair = static_cast<uint8_t>(r.u8("bit-planes"));
                p = pair & 15;
            } else {
                p = pair >> 4;
            }
            if (p > top) r.fail("a band has more bit-planes than the frame's largest");
            largest = std::max<uint32_t>(largest, p);
        }
    }
    if (packed && i % 2 == 1 && (pair >> 4) != 0) r.fail("bad bit-plane count padding");
    if (largest != top) r.fail("no band has the frame's largest bit-plane count");
    const auto rest = r.bytes(r.remaining(), "stream");
    f.stream.assign(rest.begin(), rest.end());
    return f;
}

std::vector<uint8_t> write_twv_index(const TwvIndex& index) {
    ByteWriter w;
    w.varint(index.frame_offsets.size());
    w.varint(index.group_offsets.size());
    uint64_t previous = 0;
    for (size_t i = 0; i < index.group_offsets.size(); ++i) {
        w.varint(index.group_offsets[i] - previous);
        w.varint(index.group_first[i]);
        previous = index.group_offsets[i];
    }
    previous = 0;
    for (uint64_t offset : index.frame_offsets) {
        w.varint(offset - previous);
        previous = offset;
    }
    return std::move(w.data());
}

TwvIndex read_twv_index(std::span<const uint8_t> payload, uint64_t file_size,
                        const std::string& what, const TwvLimits& limits, int version) {
    ByteReader r(payload, what);
    // Every entry takes at least one byte, so counts beyond the payload are refused up front.
    const int64_t room = static_cast<int64_t>(payload.size());
    const int64_t frames = r.count("frame count", 1, std::min(limits.max_frames, room));
    const int64_t groups = r.count("group count", 1, std::min(frames, room));
    TwvIndex index;
    uint64_t offset = 0;
    int64_t first = -1;
    for (int64_t i = 0; i < groups; ++i) {
        const auto delta = r.varint("group offset");
        if (delta == 0 && i > 0) r.fail("group offsets must increase");
        if (delta >= file_size - offset) r.fail("group offset past the end of the file");
        offset += delta;
        const int64_t f = r.count("group first frame", first + 1, frames - 1);
        if (i == 0 && f != 0) r.fail("the first group must start at frame 0");
        first = f;
        index.group_offsets.push_back(offset);
        index.group_first.push_back(f);
    }
    offset = 0;
    for (int64_t i = 0; i < frames; ++i) {
        const auto delta = r.varint("frame offset");
        // Version 5: a repeated frame shares the chunk of the frame it repeats.
        if (delta == 0 && (i == 0 || version < 5)) r.fail("frame offsets must increase");
        if (delta >= file_size - offset) r.fail("frame offset past the end of the file");
        offset += delta;
        index.frame_offsets.push_back(offset);
    }
    // Each group chunk lies before its first frame's chunk and after the previous group's frames.
    for (size_t i = 0; i < index.group_offsets.size(); ++i) {
        const size_t f = static_cast<size_t>(index.group_first[i]);
        if (index.group_offsets[i] >= index.frame_offsets[f] ||
            (f > 0 && index.group_offsets[i] <= index.frame_offsets[f - 1])) {
            r.fail(str("group ", i, " is not where its first frame says"));
        }
    }
    if (r.remaining() != 0) r.fail(str(r.remaining(), " unexpected bytes after the index"));
    return index;
}

std::vector<uint8_t> twv_trailer(uint64_t index_offset) {
    ByteWriter w;
    write_u64(w, index_offset);
    for (uint8_t b : kTwvTrailerMagic) w.u8(b);
    return std::move(w.data());
}

}  // namespace tesswave::video
