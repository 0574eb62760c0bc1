// The .twv clip file (DESIGN.md 4): a file header, then chunks, each protected by a CRC-32, then
// an index for seeking. A group chunk names the coding domain (mesh topology or fixed grid, levels,
// band norms) and is followed by the group's frame chunks: an intra frame, then deltas.
//
//   file header: magic "TWV" 0x1A | version u8 | width, height varint | fps numerator,
//     denominator varint | channels u8 (1 or 3) | bit depth u8 (8) | CRC-32 u32 of the above
//   chunk: tag u8 | payload size varint | payload | CRC-32 u32 of tag, size and payload
//   'G' group: first frame varint | transform u8 (0 mesh, 1 grid 5/3, 2 grid 9/7) | levels u8 |
//     mesh path: motion u8 (0 static, 1 tracked) | grid columns, rows varint (the T0 mesh is
//     the grid on [0,W]x[0,H]) | version 4: mesh wavelet u8 (0 the lifted bilinear, 1 the 9/7
//     on the lattice of T_J's samples; coding_domain.h) | per channel: step factor f32 | band count
//     varint | per band: norm f32 | version 2: lifted frames varint (0: a low-delay group of an
//     intra frame and closed-loop deltas; n > 0: n frames lifted along the mesh, temporal.h: on the
//     dyadic tree before version 4, on the bisection tree from it) |
//     version 3, tracked mesh path: canvas extension x, y varint (pixels, at most W and H; nonzero
//     only in a lifted group: T0 is the grid on the canvas [0,W+x]x[0,H+y] and each frame a window
//     of it)
//   'F' frame: frame number varint | kind u8 (0 intra, 1 delta, 2 temporal band: slot t of a
//     lifted group, which carries frame t's motion; version 5: plus 0x80 when a repeat count
//     follows) | version 5, with 0x80: repeats varint, at least 1 (the frame is shown 1 + repeats
//     times: the frames after it, numbered on, are copies of it) | base step f32 | a group with a
//     canvas: the frame's window on it, left and top varint (1/4 pixels, within the canvas) |
//     tracked mesh path: motion bytes varint (0: the mesh stays where it was, at rest for an intra
//     frame), then that many bytes of range-coded vertex motion | largest bit-plane count u8, and
//     unless it is 0 (nothing to add: the payload ends): per channel and band, bit-planes u8
//     (version 2 and later, with a largest count of at most 15: two a byte, low nibble first, the
//     last high nibble 0) | the embedded bit-plane stream (rest of the payload)
//   'I' index: frame count varint | group count varint | per group: chunk offset (delta from the
//     previous group's, varint) and first frame varint | per frame: chunk offset (delta from the
//     previous frame's, varint; version 5: 0 for a repeated frame, which shares its chunk)
//   trailer: offset of the index chunk u64 (little-endian) | "TWVE"
//
// A file cut anywhere decodes up to its last whole frame chunk (readers scan when the trailer is
// missing); in a lifted group, the frames whose chunks arrived, the missing bands taken as zero.
// Version 1 files (no lifted groups), version 2 files (no canvas), version 3 files (the lifted
// mesh wavelet only), version 4 files (no repeated frames) and version 5 files (bit-plane streams
// without zero blocks, bitplane.h) are read as before.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/codec/bitplane.h"
#include "core/codec/twi_format.h"

namespace tesswave::video {

inline constexpr uint8_t kTwvMagic[4] = {'T', 'W', 'V', 0x1A};
inline constexpr uint8_t kTwvTrailerMagic[4] = {'T', 'W', 'V', 'E'};
inline constexpr int kTwvTrailerBytes = 12;

struct TwvHeader {
    int width = 0, height = 0;
    int fps_num = 25, fps_den = 1;
    int channels = 3, bit_depth = 8;
    int version = 6;  // as read; written files are version 6
    double fps() const { return static_cast<double>(fps_num) / fps_den; }
};

enum class TwvMotion : uint8_t { none = 0, tracked = 1 };

struct TwvGroup {
    int64_t first_frame = 0;
    TwiTransform transform = TwiTransform::mesh;
    int levels = 0;
    TwvMotion motion = TwvMotion::none;  // mesh path
    int grid_cols = 0, grid_rows = 0;    // mesh path: T0 is grid_mesh(W, H, cols, rows)
    // Mesh path, version 4: the transform of the mesh's samples (lifted in earlier versions).
    MeshWavelet mesh_wavelet = MeshWavelet::lifted;
    std::vector<float> channel_factors = {};  // per channel
    std::vector<float> band_norms = {};       // per band of the coding layout
    int lifted = 0;  // frames of a temporally lifted group; 0: low delay (intra, then deltas)
    // Tracked mesh path, version 3, lifted groups: the canvas (W + extend_x) x (H + extend_y)
    // that T0 covers and each frame is a window of (a group whose camera pans); 0 0: the frame.
    int extend_x = 0, extend_y = 0;
    bool has_canvas() const { return extend_x > 0 || extend_y > 0; }
};

enum class TwvFrameKind : uint8_t { intra = 0, delta = 1, band = 2 };

// The most copies one frame chunk may ask for (the decoder also counts each against the work its
// file may cost).
inline constexpr int64_t kMaxRepeats = int64_t{1} << 20;

struct TwvFrame {
    int64_t number = 0;
    TwvFrameKind kind = TwvFrameKind::intra;
    int64_t repeats = 0;  // version 5: copies of this frame that follow it
    float base_step = 1.0f;
    // A group with a canvas: where the frame lies on it (its top left corner), in 1/4 pixels.
    int32_t window_x = 0, window_y = 0;
    std::vector<uint8_t> motion = {};  // range-coded vertex motion (tracked mesh path)
    PlaneCounts planes = {};           // [channel][band]
    std::vector<uint8_t> stream = {};  // bit-planes
};

struct TwvIndex {
    std::vector<uint64_t> group_offsets;  // file offset of each group chunk
    std::vector<int64_t> group_first;     // first frame of each group
    std::vector<uint64_t> frame_offsets;  // file offset of each frame chunk
};

struct TwvLimits {
    int64_t max_pixels = int64_t{1} << 26;
    int64_t max_samples = 50'000'000;     // mesh samples of T_J
    double max_samples_per_pixel = 20;    // and at most this many a pixel (plus 2^20)
    int64_t max_chunk_bytes = 256 << 20;  // a chunk's payload
    int64_t max_frames = 100'000'000;
    // What a file may claim for its size: any file may have frames of free_pixels pixels; larger
    // frames need a byte of file for each pixels_per_byte pixels of a frame. Tighter than
    // TwiLimits: a clip's frames go to an encoder (x264, FFV1) whose buffers grow with the frame,
    // about 0.27 KB a pixel for x264 and 148 bytes for FFV1's zeroed packet buffer, so 2^19 + 256
    // a byte let a 1.2 KB file of 724x724 frames cost 143 MB above the process's floor to MP4 and
    // 118 MB to MKV. A 1 KB file now has frames of at most 0.33 M pixels (572x572); a 1280x720
    // clip needs 10 KB (the encoder pads one that codes to less).
    int64_t free_pixels = int64_t{1} << 18;
    int64_t pixels_per_byte = 64;
    // A lifted group is held whole: its frames times the coefficients of a frame, 4 bytes each.
    // The encoder shortens groups to fit.
    int64_t max_group_bytes = int64_t{512} << 20;
    int max_lifted_frames = 256;
    // What decoding a file may cost, weighed against its bytes as the frame size is: the frames
    // decoded may total free_work_pixels pixels and work_pixels_per_byte more for each byte of the
    // file; a lifted group's coefficients may take free_group_bytes, and group_bytes_per_byte more
    // for each byte of the file (a 1 KB file: about 12 M pixels, 96 MiB). A group's coefficients
    // take about 96 d / b bytes for each byte of the file at density d and b bits a pixel: 9600
    // at 0.02 bpp on density 2, where 4096 refused short clips at low rates (16 frames of Big
    // Buck Bunny at 150 kbit/s).
    int64_t free_work_pixels = int64_t{1} << 23;
    int64_t work_pixels_per_byte = 4096;
    int64_t free_group_bytes = int64_t{64} << 20;
    int64_t group_bytes_per_byte = 32768;
    // A group's mesh, weighed as TwiLimits weighs a still file's: any file may have groups of
    // free_samples samples of T_J, larger ones need a byte of file for each samples_per_byte
    // samples. A mesh group's domain costs its decoder about 160 bytes a sample, so a 1 KB file
    // may cost about 40 MiB there (a 101-byte file claiming 11.5 M samples took 1.9 GiB before).
    int64_t free_samples = int64_t{1} << 17;
    int64_t samples_per_byte = 128;
};

// The work one decoded frame is charged, in pixels: its own, and at least 4096 for its fixed costs
// (a chunk, a render, a frame written), so that a clip of tiny frames, or repeats that take no
// bytes, cannot claim millions of frames from a small file.
inline int64_t twv_frame_work(int64_t pixels) { return std::max<int64_t>(pixels, 4096); }

// The frame pixels, and the bytes of one lifted group's coefficients, that decoding a file of
// `file_bytes` bytes may cost within `limits` (saturating).
int64_t twv_work_allowed(int64_t file_bytes, const TwvLimits& limits = {});
int64_t twv_group_bytes_allowed(int64_t file_bytes, const TwvLimits& limits = {});
// The mesh samples of T_J a group of a file of `file_bytes` bytes may have (saturating).
int64_t twv_samples_allowed(int64_t file_bytes, const TwvLimits& limits = {});

// The samples of a mesh group's T_J (0 for a fixed-grid group, whose cost the frame size bounds).
int64_t twv_group_samples(const TwvGroup& group);

// Why a group's mesh (or its lifted frames) is too large for the limits (empty: it is not): the
// one check of the decoder and the encoder.
std::string twv_group_size_problem(const TwvGroup& group, const TwvHeader& header,
                                   const TwvLimits& limits = {});

// The bytes a .twv file needs so that `limits` let it have frames of `pixels` pixels.
int64_t twv_bytes_needed(int64_t pixels, const TwvLimits& limits = {});

// The bytes a .twv file needs so that `limits` let it have frames of `pixels` pixels, decode
// `frames` of them, hold lifted groups of `group_bytes` bytes of coefficients and have mesh groups
// of `samples` samples; the largest int64_t when no size will do (a group above max_group_bytes).
int64_t twv_file_bytes_needed(int64_t pixels, int64_t frames, int64_t group_bytes, int64_t samples,
                              const TwvLimits& limits = {});

// The bytes one frame's coefficients take in memory (all channels).
int64_t twv_frame_coefficient_bytes(const TwvGroup& group, const TwvHeader& header);

// The bytes a lifted group's coefficients take in memory while it is decoded (0 for a
// low-delay group): what the decoder and the encoder weigh against twv_group_bytes_allowed.
int64_t twv_lifted_group_bytes(const TwvGroup& group, const TwvHeader& header);
// The most frames a lifted group may have within the limits (at least 1).
int twv_max_lifted_frames(const TwvGroup& group, const TwvHeader& header,
                          const TwvLimits& limits = {});

std::vector<uint8_t> write_twv_header(const TwvHeader& header);
// `file` holds at least the header; `name` prefixes messages. Returns the header's size in `used`.
TwvHeader read_twv_header(std::span<const uint8_t> file, const std::string& name, size_t& used,
                          const TwvLimits& limits = {});

// A whole chunk (tag, size, payload, CRC). Tags: 'G' group, 'F' frame, 'I' index, 'P' padding
// (zeros a decoder skips: what a very compressible clip adds so that its decoding stays within
// the work its size may claim).
std::vector<uint8_t> twv_chunk(uint8_t tag, std::span<const uint8_t> payload);

// Padding chunks ('P') of at least `bytes` bytes in all, exactly `bytes` when that is 6 or more
// (a chunk's least size), each with a payload of at most `most` zeros (a decoder reads a chunk
// whole).
std::vector<std::vector<uint8_t>> twv_padding(int64_t bytes, int64_t most = int64_t{1} << 20);

std::vector<uint8_t> write_twv_group(const TwvGroup& group);
// Checks the group against the clip (sizes, band counts, the limits); `what` prefixes messages.
TwvGroup read_twv_group(std::span<const uint8_t> payload, const TwvHeader& header,
                        const std::string& what, const TwvLimits& limits = {});
// The number of bands the group's coding layout has.
int twv_band_count(const TwvGroup& group, const TwvHeader& header);

std::vector<uint8_t> write_twv_frame(const TwvFrame& frame, const TwvGroup& group);
TwvFrame read_twv_frame(std::span<const uint8_t> payload, const TwvGroup& group,
                        const TwvHeader& header, const std::string& what);

std::vector<uint8_t> write_twv_index(const TwvIndex& index);
// Offsets must increase (from version 5 a repeated frame's may equal the one before) and lie
// before `file_size`; frames must be in their groups' order.
TwvIndex read_twv_index(std::span<const uint8_t> payload, uint64_t file_size,
                        const std::string& what, const TwvLimits& limits, int version);
std::vector<uint8_t> twv_trailer(uint64_t index_offset);

}  // namespace tesswave::video
