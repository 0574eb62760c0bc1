#include "core/codec/twi_format.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "core/codec/byte_io.h"
#include "core/math/error.h"
#include "core/math/fixed_grid.h"
#include "core/math/grid_mesh.h"
#include "core/math/hierarchy.h"
#include "core/math/strings.h"
#include "core/math/validate.h"

namespace tesswave {
namespace {

constexpr uint8_t kMagic[4] = {'T', 'W', 'I', 0x1A};
constexpr uint32_t kVersion = 4;
constexpr double kVertexUnit = 256.0;
constexpr int64_t kMaxCoordinate = int64_t{1} << 40;  // in vertex units, either sign

void write_mesh(ByteWriter& w, const TwiHeader& h) {
    w.u8(static_cast<uint8_t>(h.placement));
    if (h.grid_cols > 0) {
        w.u8(0);
        w.varint(h.grid_cols);
        w.varint(h.grid_rows);
        w.u8(static_cast<uint8_t>(h.mesh_wavelet));
        return;
    }
    const Mesh& m = h.mesh;
    w.u8(1);
    w.varint(m.vertices.size());
    int64_t px = 0, py = 0;
    for (const Vec2& p : m.vertices) {
        const int64_t x = std::llround(p.x * kVertexUnit), y = std::llround(p.y * kVertexUnit);
        w.svarint(x - px);
        w.svarint(y - py);
        px = x;
        py = y;
    }
    w.varint(m.num_faces());
    int64_t prev = 0;
    for (int f = 0; f < m.num_faces(); ++f) {
        w.varint(m.face(f).size());
        for (int32_t v : m.face(f)) {
            w.svarint(v - prev);
            prev = v;
        }
    }
    w.varint(m.features.size());
    for (const auto& e : m.features) {
        w.varint(e[0]);
        w.varint(e[1]);
    }
}

// Adds a delta to a running value in [-bound, bound]; false when the sum leaves that range. The
// delta is checked first, so that the sum cannot overflow whatever the file says.
bool add_delta(int64_t& value, int64_t delta, int64_t bound) {
    if (delta < -2 * bound || delta > 2 * bound) return false;
    value += delta;
    return value >= -bound && value <= bound;
}

// A count in [lo, hi] of items that take at least `bytes_each` bytes each: more than the bytes
// that remain can hold means a cut file, and the message says so.
int64_t fitting_count(ByteReader& r, const char* field, int64_t lo, int64_t hi,
                      int64_t bytes_each) {
    const int64_t n = r.count(field, lo, hi);
    if (n > static_cast<int64_t>(r.remaining()) / bytes_each) {
        r.fail(str("truncated: ", field, " ", n, " needs at least ", bytes_each,
                   " bytes per item, ", r.remaining(), " remain"));
    }
    return n;
}

void read_mesh(ByteReader& r, TwiHeader& h, const TwiLimits& limits, const std::string& name) {
    h.placement = static_cast<MeshPlacement>(r.count("mesh placement", 0, 1));
    const double W = h.width, H = h.height;
    const int kind = static_cast<int>(r.u8("mesh kind"));
    if (kind == 0) {
        h.grid_cols = static_cast<int>(r.count("grid columns", 1, h.width));
        h.grid_rows = static_cast<int>(r.count("grid rows", 1, h.height));
        if (h.version >= 3) {
            h.mesh_wavelet = static_cast<MeshWavelet>(r.count("mesh wavelet", 0, 1));
            if (h.mesh_wavelet == MeshWavelet::lattice97 &&
                (h.lossless || h.placement != MeshPlacement::area)) {
                r.fail("the 9/7 on the mesh's lattice is for lossy grids placed by area");
            }
        }
        if (int64_t{h.grid_cols} * h.grid_rows > limits.max_mesh_vertices) {
            r.fail(str("a ", h.grid_cols, "x", h.grid_rows, " grid mesh exceeds the vertex limit"));
        }
        if (h.placement == MeshPlacement::centres) {
            const int64_t cell = int64_t{1} << h.levels;
            if (h.grid_cols != aligned_cells(h.width, h.levels) ||
                h.grid_rows != aligned_cells(h.height, h.levels)) {
                r.fail("grid size does not match the image for a mesh on pixel centres");
            }
            h.mesh = grid_mesh(h.grid_cols * cell, h.grid_rows * cell, h.grid_cols, h.grid_rows);
        } else {
            h.mesh = grid_mesh(W, H, h.grid_cols, h.grid_rows);
        }
    } else if (kind == 1) {
        if (h.placement == MeshPlacement::centres) r.fail("a mesh on pixel centres must be a grid");
        Mesh& m = h.mesh;
        m.width = W;
        m.height = H;
        // Each vertex takes at least 2 bytes, each face at least 4 (count and 3 corners).
        const int64_t nv = fitting_count(r, "vertex count", 3, limits.max_mesh_vertices, 2);
        m.vertices.resize(nv);
        int64_t x = 0, y = 0;
        for (Vec2& p : m.vertices) {
            if (!add_delta(x, r.svarint("vertex x"), kMaxCoordinate) ||
                !add_delta(y, r.svarint("vertex y"), kMaxCoordinate)) {
                r.fail("vertex coordinate out of range");
            }
            p = {x / kVertexUnit, y / kVertexUnit};
        }
        constexpr int64_t kMaxCount = std::numeric_limits<int32_t>::max();
        const int64_t nf = fitting_count(r, "face count", 1, kMaxCount, 4);
        int64_t prev = 0;
        std::vector<int32_t> corners;
        for (int64_t f = 0; f < nf; ++f) {
            const int64_t k = fitting_count(r, "face corner count", 3, nv, 1);
            corners.resize(k);
            for (int32_t& c : corners) {
                const int64_t delta = r.svarint("face corner");
                if (delta <= -nv || delta >= nv || prev + delta < 0 || prev + delta >= nv) {
                    r.fail(str("face ", f, ": corner id ", prev, " + ", delta, " out of range"));
                }
                prev += delta;
                c = static_cast<int32_t>(prev);
            }
            m.add_face(corners);
        }
        const int64_t ne = fitting_count(r, "feature count", 0, kMaxCount, 2);
        m.features.resize(ne);
        for (auto& e : m.features) {
            e[0] = static_cast<int32_t>(r.count("feature vertex", 0, nv - 1));
            e[1] = static_cast<int32_t>(r.count("feature vertex", 0, nv - 1));
        }
    } else {
        r.fail(str("unknown mesh kind ", kind));
    }
    (void)name;
}

// The samples of T_J against the limits and the file's bytes (after the CRC: an explicit mesh's
// counts are only trusted, and it is only validated, once the header is known to be intact).
void check_mesh_size(ByteReader& r, const TwiHeader& h, const TwiLimits& limits,
                     size_t file_bytes) {
    const int64_t samples = sample_count(h.mesh, h.levels);
    const double per_pixel_cap =
        limits.max_samples_per_pixel * (static_cast<double>(h.width) * h.height) + (1 << 20);
    if (samples > limits.max_samples || static_cast<double>(samples) > per_pixel_cap) {
        r.fail(str("the mesh has ", samples, " samples at level ", h.levels, " (limit ",
                   limits.max_samples, ", and ", limits.max_samples_per_pixel, " a pixel)"));
    }
    const int64_t needed = twi_bytes_needed(0, samples, limits);
    if (static_cast<int64_t>(file_bytes) < needed) {
        r.fail(str(samples, " mesh samples in a ", file_bytes, "-byte file (a file needs ", needed,
                   " bytes to claim that many; --max-pixels raises the limit)"));
    }
}

}  // namespace

int64_t twi_bytes_needed(int64_t pixels, int64_t samples, const TwiLimits& limits) {
    auto need = [](int64_t count, int64_t free, int64_t per_byte) -> int64_t {
        return count <= free ? 0 : (count - free + per_byte - 1) / std::max<int64_t>(per_byte, 1);
    };
    return std::max(need(pixels, limits.free_pixels, limits.pixels_per_byte),
                    need(samples, limits.free_samples, limits.samples_per_byte));
}

void round_mesh_vertices(Mesh& mesh) {
    require_valid(mesh, "mesh");  // the repair below reads the faces' corners
    const std::vector<Vec2> exact = mesh.vertices;
    // Convex and counterclockwise, as validate() wants every face of a valid mesh.
    const auto convex_face = [&](int f) {
        return first_bad_corner(mesh, mesh.vertices, f) == -1 &&
               face_signed_area(mesh, mesh.vertices, f) > 0;
    };
    const auto round = [](double v) { return std::round(v * kVertexUnit) / kVertexUnit; };
    for (Vec2& p : mesh.vertices) p = {round(p.x), round(p.y)};
    // Rounding can push a corner that is nearly straight (Voronoi cells have many) past 180
    // degrees. The vertex of such a corner then takes the lattice point nearest its exact position,
    // within 3 units of its rounded one, at which every face around it is convex; a vertex on the
    // domain's border moves along it. Vertices that find none stay rounded (validation names them).
    std::vector<std::vector<int>> faces_of(mesh.vertices.size());
    for (int f = 0; f < mesh.num_faces(); ++f) {
        for (int32_t v : mesh.face(f)) faces_of[v].push_back(f);
    }
    const auto all_convex = [&](int32_t v) {
        for (int f : faces_of[v]) {
            if (!convex_face(f)) return false;
        }
        return true;
    };
    constexpr int kReach = 3;
    std::vector<std::array<int, 2>> steps;
    for (int dy = -kReach; dy <= kReach; ++dy) {
        for (int dx = -kReach; dx <= kReach; ++dx) {
            if (dx != 0 || dy != 0) steps.push_back({dx, dy});
        }
    }
    for (int pass = 0; pass < 4; ++pass) {
        bool moved = false;
        for (int f = 0; f < mesh.num_faces(); ++f) {
            if (convex_face(f)) continue;
            for (int32_t v : mesh.face(f)) {
                if (all_convex(v)) continue;
                const Vec2 rounded = mesh.vertices[v];
                const bool fixed_x = exact[v].x == 0 || exact[v].x == mesh.width;
                const bool fixed_y = exact[v].y == 0 || exact[v].y == mesh.height;
                std::vector<Vec2> candidates;
                for (const auto& [dx, dy] : steps) {
                    if ((fixed_x && dx != 0) || (fixed_y && dy != 0)) continue;
                    const Vec2 c{rounded.x + dx / kVertexUnit, rounded.y + dy / kVertexUnit};
                    if (c.x < 0 || c.x > mesh.width || c.y < 0 || c.y > mesh.height) continue;
                    candidates.push_back(c);
                }
                std::stable_sort(candidates.begin(), candidates.end(),
                                 [&](const Vec2& a, const Vec2& b) {
                                     return norm(a - exact[v]) < norm(b - exact[v]);
                                 });
                for (const Vec2& c : candidates) {
                    mesh.vertices[v] = c;
                    if (all_convex(v)) break;
                    mesh.vertices[v] = rounded;
                }
                moved |= mesh.vertices[v] != rounded;
            }
        }
        if (!moved) break;
    }
}

int aligned_cells(int pixels, int levels) {
    return std::max(
        1, static_cast<int>(((int64_t{pixels} - 1 + (int64_t{1} << levels) - 1) >> levels)));
}

int coding_band_count(TwiTransform transform, MeshWavelet wavelet, int levels, int width,
                      int height) {
    if (transform == TwiTransform::mesh) {
        return (wavelet == MeshWavelet::lattice97 ? 3 : 2) * levels + 1;
    }
    return static_cast<int>(grid_bands(width, height, levels).size());
}

int expected_bands(const TwiHeader& h) {
    return coding_band_count(h.transform, h.mesh_wavelet, h.levels, h.width, h.height);
}

BitplaneOptions twi_stream_options(const TwiHeader& header) {
    return {
        .shifts = header.shifts, .fast_start = header.version >= 2, .blocks = header.version >= 4};
}

std::vector<uint8_t> write_twi_header(const TwiHeader& h) {
    ByteWriter w;
    for (uint8_t b : kMagic) w.u8(b);
    w.u8(kVersion);
    w.u8(h.lossless ? 1 : 0);
    w.u8(static_cast<uint8_t>(h.transform));
    w.u8(static_cast<uint8_t>(h.colour));
    w.u8(h.channels);
    w.u8(h.bit_depth);
    w.varint(h.width);
    w.varint(h.height);
    w.u8(h.levels);
    if (h.transform == TwiTransform::mesh) write_mesh(w, h);
    w.f32(h.base_step);
    for (float f : h.channel_factors) w.f32(f);
    w.varint(h.band_norms.size());
    for (size_t b = 0; b < h.band_norms.size(); ++b) {
        w.f32(h.band_norms[b]);
        w.u8(h.shifts[b]);
    }
    for (const auto& channel : h.planes) {
        for (uint8_t n : channel) w.u8(n);
    }
    w.u32(crc32(w.data()));
    return std::move(w.data());
}

TwiHeader read_twi_header(std::span<const uint8_t> file, const std::string& name,
                          const TwiLimits& limits) {
    ByteReader r(file, name);
    if (file.size() < 4 || !std::equal(kMagic, kMagic + 4, file.begin())) {
        r.fail("not a .twi file (bad magic)");
    }
    r.bytes(4, "magic");
    TwiHeader h;
    const uint32_t version = r.u8("version");
    if (version < 1 || version > kVersion) r.fail(str("unsupported .twi version ", version));
    h.version = static_cast<int>(version);
    const uint32_t flags = r.u8("flags");
    if (flags > 1) r.fail(str("unknown flags ", flags));
    h.lossless = flags & 1;
    h.transform = static_cast<TwiTransform>(r.u8("transform"));
    if (static_cast<int>(h.transform) > 2) r.fail("unknown transform");
    const uint32_t colour = r.u8("colour");
    if (colour > 2) r.fail("unknown colour transform");
    h.colour = static_cast<TwiColour>(colour);
    h.channels = static_cast<int>(r.u8("channels"));
    if (h.channels < 1 || h.channels > 4) r.fail(str(h.channels, " channels (1 to 4 allowed)"));
    if (h.colour != TwiColour::none && h.channels < 3) r.fail("colour transform needs 3 channels");
    h.bit_depth = static_cast<int>(r.u8("bit depth"));
    if (h.bit_depth != 8 && h.bit_depth != 16) r.fail(str("bit depth ", h.bit_depth));
    h.width = static_cast<int>(r.count("width", 1, kMaxTwiSide));
    h.height = static_cast<int>(r.count("height", 1, kMaxTwiSide));
    const int64_t pixels = int64_t{h.width} * h.height;
    if (pixels > limits.max_pixels) {
        r.fail(str(h.width, "x", h.height, " pixels exceed the limit of ", limits.max_pixels));
    }
    if (static_cast<int64_t>(file.size()) < twi_bytes_needed(pixels, 0, limits)) {
        r.fail(str(h.width, "x", h.height, " pixels in a ", file.size(),
                   "-byte file (a file needs ", twi_bytes_needed(pixels, 0, limits),
                   " bytes to claim that many; --max-pixels raises the limit)"));
    }
    h.levels = static_cast<int>(r.u8("levels"));
    if (h.levels > (h.transform == TwiTransform::mesh ? 12 : 20)) r.fail("too many levels");
    if (h.transform == TwiTransform::mesh && h.levels < 1)
        r.fail("mesh level J must be at least 1");
    if (h.transform == TwiTransform::mesh) read_mesh(r, h, limits, name);
    h.base_step = r.f32("base step");
    if (!(h.base_step > 0)) r.fail("the base step must be positive");
    for (int c = 0; c < h.channels; ++c) {
        h.channel_factors.push_back(r.f32("channel step factor"));
        if (!(h.channel_factors.back() > 0)) r.fail("channel step factors must be positive");
    }
    const int bands = expected_bands(h);
    if (r.varint("band count") != static_cast<uint64_t>(bands)) {
        r.fail(str("band count does not match the transform (", bands, " expected)"));
    }
    for (int b = 0; b < bands; ++b) {
        h.band_norms.push_back(r.f32("band norm"));
        if (!(h.band_norms.back() > 0)) r.fail("band norms must be positive");
        h.shifts.push_back(static_cast<int>(r.u8("band shift")));
        if (h.shifts.back() > 32) r.fail("band shift above 32");
    }
    h.planes.assign(h.channels, std::vector<uint8_t>(bands));
    for (auto& channel : h.planes) {
        for (uint8_t& n : channel) {
            n = static_cast<uint8_t>(r.u8("bit-plane count"));
            if (n > 31) r.fail("bit-plane count above 31");
        }
    }
    const uint32_t expected = crc32(file.first(r.position()));
    if (r.u32("header CRC") != expected) r.fail("header CRC mismatch (corrupted file)");
    h.header_bytes = r.position();
    if (h.transform == TwiTransform::mesh) {
        check_mesh_size(r, h, limits, file.size());
        if (h.grid_cols == 0) require_valid(h.mesh, name + ": mesh");  // explicit: check it
    }
    return h;
}

}  // namespace tesswave
