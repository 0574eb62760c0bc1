// The .twi still-image file: a header (fields below, CRC-32 protected) followed by the embedded
// bit-plane stream, which runs to the end of the file. Any cut of the stream is a valid file.
// Version 4 streams code zero blocks; earlier ones are read as before (twi_stream_options).
//
//   magic "TWI" 0x1A | version u8 | flags u8 (bit 0 lossless) | transform u8 (0 mesh, 1 grid 5/3,
//   2 grid 9/7) | colour u8 (0 none, 1 YCbCr, 2 YCoCg-R) | channels u8 | bit depth u8 |
//   width, height varint | levels u8 |
//   mesh path only: placement u8 (0 domain = pixel rectangle, 1 vertices on pixel centres, a
//     grid whose size follows from the image and J) |
//     mesh kind u8: 0 grid (columns, rows varint; from version 3: mesh wavelet u8, 0 the lifted
//     bilinear, 1 the 9/7 on the lattice of T_J's samples, for lossy area placement) or 1 explicit
//     (vertex count, coordinates as zigzag varint deltas in 1/256 pixel; face count, per face its
//     corner count and zigzag varint deltas of the corner ids; feature count, feature edges as
//     corner-id pairs) |
//   base step f32 | per channel: step factor f32 | band count varint | per band: norm f32 and
//   plane shift u8 | per channel and band: bit-planes u8 | CRC-32 of all the bytes above u32
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/codec/bitplane.h"
#include "core/math/mesh.h"

namespace tesswave {

enum class TwiTransform : uint8_t { mesh = 0, grid53 = 1, grid97 = 2 };
// The wavelet of the mesh path: the paper's lifted bilinear wavelet (any mesh), or the CDF 9/7
// (fixed_grid.h) on the lattice of T_J's samples, for a grid T0 (grid_lattice_index): the mesh
// still moves and samples the image; only the transform of its samples changes. Lossy only
// (.twv version 4, .twi version 3).
enum class MeshWavelet : uint8_t { lifted = 0, lattice97 = 1 };
enum class TwiColour : uint8_t { none = 0, ycbcr = 1, ycocg_r = 2 };
enum class MeshPlacement : uint8_t { area = 0, centres = 1 };

struct TwiHeader {
    int version = 4;  // as read; written files are version 4
    TwiTransform transform = TwiTransform::mesh;
    bool lossless = false;
    TwiColour colour = TwiColour::none;
    int channels = 1, bit_depth = 8, width = 0, height = 0, levels = 0;
    // Mesh path: the T0 mesh. Area placement: over the pixel rectangle [0,W]x[0,H]. Centres: a
    // grid whose level-J vertices are the pixel centres, mesh point (x, y) at pixel (x, y); its
    // domain [0, c 2^J] x [0, r 2^J] reaches past the last pixel by less than 2^J (samples there
    // repeat the edge pixels and are dropped when rendering).
    MeshPlacement placement = MeshPlacement::area;
    int grid_cols = 0, grid_rows = 0;  // > 0: the mesh is grid_mesh(...) and stored as such
    // Version 3, a lossy grid by area: the transform of its samples (version 1 and 2: lifted).
    MeshWavelet mesh_wavelet = MeshWavelet::lifted;
    Mesh mesh;
    float base_step = 1.0f;
    std::vector<float> channel_factors;  // per channel
    std::vector<float> band_norms;       // per band of the coding layout
    std::vector<int> shifts;             // per band
    PlaneCounts planes;                  // [channel][band]
    size_t header_bytes = 0;             // set by read_twi_header
};

// Decoding takes about 100 bytes a pixel (grid) or a mesh sample, so the defaults bound a
// header's claims to a few GB: 2^26 pixels (e.g. 8192 x 8192), and mesh samples at most 50 M and
// at most 20 a pixel (plus 2^20 for tiny images; the encoder offers up to 16).
// The longest side a .twi image may have (image files: PNG takes up to 10^6, JPEG 65535).
constexpr int kMaxTwiSide = 65535;

struct TwiLimits {
    int64_t max_pixels = int64_t{1} << 26;
    int64_t max_samples = 50'000'000;  // mesh samples of T_J
    double max_samples_per_pixel = 20;
    int max_mesh_vertices = 1'000'000;
    // What a file may claim for its size, so that a tiny file cannot cost much memory or time to
    // decode (decoding takes about 110 bytes a pixel on the fixed grid, and 300 a mesh sample):
    // any file may claim free_pixels pixels and free_samples samples; more need a byte of file
    // for each pixels_per_byte pixels or samples_per_byte samples. A 1 KB file may claim 0.8 M
    // pixels and 0.26 M samples (a 1920x1080 image needs 6 KB on the grid, 15 KB on a mesh of a
    // sample a pixel). The encoder refuses to write what this refuses to read.
    int64_t free_pixels = int64_t{1} << 19;
    int64_t pixels_per_byte = 256;
    int64_t free_samples = int64_t{1} << 17;
    int64_t samples_per_byte = 128;
};

// The bytes a file needs so that `limits` let it claim `pixels` pixels and `samples` mesh samples
// (0 for the fixed grid).
int64_t twi_bytes_needed(int64_t pixels, int64_t samples, const TwiLimits& limits = {});

// Quantizes explicit mesh vertices to the file's 1/256-pixel grid (the encoder codes the mesh the
// decoder will see). A vertex at a corner that rounding turns straight or reflex moves to a lattice
// point within 3/256 pixel of its rounded position at which its faces are convex (along the
// border for a border vertex), so that a valid mesh stays valid where it can. Throws Error for an
// invalid mesh.
void round_mesh_vertices(Mesh& mesh);

std::vector<uint8_t> write_twi_header(const TwiHeader& header);

// How the stream after this header is coded: its bands' shifts, models that learn fast while
// fresh from version 2 (range_coder.h), zero blocks from version 4 (bitplane.h).
BitplaneOptions twi_stream_options(const TwiHeader& header);

// Reads and checks the header; `name` prefixes messages. The sizes are checked against the limits
// and against the bytes of `file` (the whole file) before anything is allocated for them, and the
// header CRC before an explicit mesh is validated.
TwiHeader read_twi_header(std::span<const uint8_t> file, const std::string& name,
                          const TwiLimits& limits = {});

// The number of coding bands of a transform at `levels`: 1 + 2 J for the mesh's lifted wavelet,
// 1 + 3 J on its lattice (every level keeps both sides at 2 or more: cells 2^l + 1), the fixed
// grid's bands of a width x height plane. Shared by the .twi and .twv readers.
int coding_band_count(TwiTransform transform, MeshWavelet wavelet, int levels, int width,
                      int height);

// The number of coding bands the header's transform has.
int expected_bands(const TwiHeader& header);

// Columns (rows) of the grid on pixel centres: ceil((pixels - 1) / 2^J), at least 1.
int aligned_cells(int pixels, int levels);

}  // namespace tesswave
