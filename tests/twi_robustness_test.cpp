// Bad input for the .twi decoder (STYLE.md, "Errors and limits"): every byte of small files
// flipped, every truncation, files that are not .twi at all, headers with a valid CRC that claim
// absurd sizes or carry an invalid mesh. decompress_image must throw tesswave::Error with a
// one-line message naming the problem, or (for damage after the CRC-protected header, and for any
// cut after it) return an image of the header's size; it never crashes, hangs or allocates past its
// limits. Every class of file is covered: the mesh path with a grid mesh and an explicit mesh, the
// mesh on pixel centres (--aligned), and the fixed grid with the 5/3 and the 9/7, lossy and
// lossless.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <new>
#include <random>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "core/byte_io.h"
#include "core/error.h"
#include "core/grid_mesh.h"
#include "core/image_io.h"
#include "core/still_codec.h"
#include "core/strings.h"
#include "core/twi_format.h"
#include "core/validate.h"
#include "robustness.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"

namespace tesswave {
namespace {

using testing::expect_error_or_return_in_child;
using testing::Outcome;
using testing::outcome_of;
using Bytes = std::vector<uint8_t>;

// Limits for headers that claim more than a test should decode: small enough that a decoder which
// believed them would still finish quickly, and far below what the absurd headers claim.
constexpr TwiLimits kSmall{
    .max_pixels = 1 << 16, .max_samples = 1 << 16, .max_mesh_vertices = 4096};

// The procedural scene quantized to 8 bits, like a file's pixels.
Image scene(int w, int h) {
    Image image = samples::scene_image(w, h);
    for (auto& plane : image.planes) {
        for (float& v : plane) v = std::round(std::clamp(v, 0.0f, 1.0f) * 255.0f) / 255.0f;
    }
    return image;
}

// One small file of each class.
struct Coded {
    std::string name;
    StillResult result;
};

const std::vector<Coded>& coded_files() {
    static const std::vector<Coded> files = [] {
        const Image small = scene(24, 20), wide = scene(40, 30);
        const Mesh paper = samples::paper_t0(40, 30);
        const auto grid53 = TwiTransform::grid53, grid97 = TwiTransform::grid97;
        std::vector<Coded> out;
        auto add = [&](std::string name, const Image& image, const StillOptions& o) {
            out.push_back({std::move(name), compress_image(image, o)});
        };
        add("grid mesh, lossy", small, {.max_bytes = 300});
        add("grid mesh, lossless", small, {.lossless = true});
        add("explicit mesh, lossy", wide, {.max_bytes = 400, .mesh = paper, .levels = 2});
        add("explicit mesh, lossless", wide, {.lossless = true, .mesh = paper, .levels = 2});
        add("aligned mesh, lossy", small, {.max_bytes = 300, .aligned = true});
        add("aligned mesh, lossless", small, {.lossless = true, .aligned = true});
        add("grid 5/3, lossy", small, {.transform = grid53, .max_bytes = 300});
        add("grid 5/3, lossless", small, {.transform = grid53, .lossless = true});
        add("grid 9/7, lossy", wide, {.transform = grid97, .max_bytes = 400});
        return out;
    }();
    return files;
}

const Coded& file_of(std::string_view name) {
    for (const Coded& c : coded_files()) {
        if (c.name == name) return c;
    }
    throw Error(str("no test file ", name));
}

// What decoding one input did, counted; the first few failures are reported with the input's
// description.
struct Tally {
    std::string name;
    int errors = 0, decoded = 0, failures = 0;

    void fail(const std::string& input, const std::string& what) {
        if (++failures <= 5) ADD_FAILURE() << name << ": " << input << ": " << what;
    }
    // Decodes `file`; the result must be an Error with a one-line message or an image of the
    // header's size with finite samples. Returns the outcome for further checks.
    Outcome decode(std::span<const uint8_t> file, const TwiHeader& header,
                   const std::string& input) {
        Image image;
        const Outcome o = outcome_of([&] { image = decompress_image(file, "t.twi"); });
        if (o.kind == Outcome::other) {
            fail(input, "threw something other than tesswave::Error: " + o.what);
        } else if (o.kind == Outcome::error) {
            ++errors;
            check_message(o.what, input);
        } else {
            ++decoded;
            if (image.width != header.width || image.height != header.height ||
                image.channels() != header.channels) {
                fail(input, str("decoded to ", image.width, "x", image.height, "x",
                                image.channels(), ", the header says ", header.width, "x",
                                header.height, "x", header.channels));
            }
            for (const auto& plane : image.planes) {
                if (!std::all_of(plane.begin(), plane.end(),
                                 [](float v) { return std::isfinite(v); })) {
                    fail(input, "decoded samples are not finite");
                    break;
                }
            }
        }
        return o;
    }
    void check_message(const std::string& message, const std::string& input) {
        if (message.rfind("t.twi: ", 0) != 0 || message.size() <= 7 ||
            message.find('\n') != std::string::npos) {
            fail(input, "the message is not one line naming the file: \"" + message + "\"");
        }
    }
    void report() const {
        std::printf("[ twi robustness ] %s: %d errors, %d decoded, %d failures\n", name.c_str(),
                    errors, decoded, failures);
        ::testing::Test::RecordProperty("errors", errors);
        ::testing::Test::RecordProperty("decoded", decoded);
        EXPECT_EQ(failures, 0) << name;
    }
};

// The last 4 bytes of a header replaced by the CRC of the bytes before them.
Bytes with_crc(const Bytes& header) {
    const std::span<const uint8_t> body = std::span(header).first(header.size() - 4);
    ByteWriter w;
    w.bytes(body);
    w.u32(crc32(body));
    return w.data();
}

Bytes varint_bytes(uint64_t v) {
    ByteWriter w;
    w.varint(v);
    return w.data();
}

std::string message_of(std::span<const uint8_t> file, const StillDecodeOptions& options = {}) {
    const Outcome o = outcome_of([&] { decompress_image(file, "t.twi", options); });
    if (o.kind == Outcome::error) return o.what;
    return o.kind == Outcome::returned ? "(decoded)" : "(other exception) " + o.what;
}

// Expects decoding to fail with an Error whose message contains `word`.
void expect_refused(std::span<const uint8_t> file, std::string_view word,
                    const StillDecodeOptions& options = {}) {
    const std::string message = message_of(file, options);
    EXPECT_TRUE(message.rfind("t.twi: ", 0) == 0 && message.find(word) != std::string::npos &&
                message.find('\n') == std::string::npos)
        << "expected an Error about \"" << word << "\", got: " << message;
}

// ---- 1. Single-byte damage ----

// Every header byte is tried; in the stream, every byte at -O3 (the campaigns below take about
// 3 s) and every 4th under AddressSanitizer, where each decode costs about 20 ms with the slow
// unwinder run.sh asks for.
#if defined(__SANITIZE_ADDRESS__)
constexpr size_t kStreamStride = 4;
#else
constexpr size_t kStreamStride = 1;
#endif

// The next position to try after `at` in a file whose header has `header_bytes` bytes.
size_t next_position(size_t at, size_t header_bytes) {
    return at < header_bytes ? at + 1 : at + kStreamStride;
}

TEST(TwiRobustness, every_flipped_byte_is_refused_in_the_header_and_decodes_in_the_stream) {
    for (const Coded& c : coded_files()) {
        const Bytes& file = c.result.file;
        const TwiHeader& h = c.result.header;
        for (const char* how : {"xor 0xFF", "one bit"}) {
            Tally header{str(c.name, ", header, ", how)}, stream{str(c.name, ", stream, ", how)};
            for (size_t at = 0; at < file.size(); at = next_position(at, h.header_bytes)) {
                Bytes damaged = file;
                damaged[at] ^= how[0] == 'x' ? 0xFF : 1 << (at % 8);
                const std::string input = str("byte ", at, " of ", file.size(), " ", how);
                (at < h.header_bytes ? header : stream).decode(damaged, h, input);
            }
            EXPECT_EQ(header.errors, static_cast<int>(h.header_bytes)) << header.name;
            EXPECT_EQ(stream.errors, 0) << stream.name;
            EXPECT_GT(stream.decoded, 0) << stream.name;
            header.report();
            stream.report();
        }
    }
}

// ---- 2. Truncation ----

TEST(TwiRobustness, every_cut_inside_the_header_is_refused_and_every_cut_after_it_decodes) {
    for (const Coded& c : coded_files()) {
        const Bytes& file = c.result.file;
        const TwiHeader& h = c.result.header;
        Tally tally{c.name + ", truncated"};
        for (size_t n = 0; n <= file.size(); n = next_position(n, h.header_bytes)) {
            const std::span<const uint8_t> prefix(file.data(), n);
            const Outcome o = tally.decode(prefix, h, str(n, " of ", file.size(), " bytes"));
            const bool refused = o.kind == Outcome::error;
            if (refused != (n < h.header_bytes)) {
                tally.fail(str(n, " bytes"), refused ? "refused: " + o.what : "decoded");
            }
            const char* word = n < 4 ? "magic" : "truncated";
            if (refused && o.what.find(word) == std::string::npos) {
                tally.fail(str(n, " bytes"),
                           str("the message does not say \"", word, "\": ", o.what));
            }
        }
        EXPECT_EQ(tally.errors, static_cast<int>(h.header_bytes)) << tally.name;
        tally.report();
    }
}

// The decoder's own max_bytes cuts the same way as a short file.
TEST(TwiRobustness, a_byte_limit_cuts_like_a_short_file) {
    const Coded& c = file_of("explicit mesh, lossy");
    const size_t header = c.result.header.header_bytes;
    EXPECT_THROW(decompress_image(c.result.file, "t.twi", {.max_bytes = header - 1}), Error);
    EXPECT_EQ(decompress_image(c.result.file, "t.twi", {.max_bytes = header}).width, 40);
}

// ---- 3. Files that are not .twi files ----

TEST(TwiRobustness, files_that_are_not_twi_are_refused_naming_the_problem) {
    const Bytes& valid = file_of("grid mesh, lossy").result.file;
    const auto header_bytes =
        static_cast<std::ptrdiff_t>(file_of("grid mesh, lossy").result.header.header_bytes);
    expect_refused({}, "magic");
    for (size_t n = 1; n <= 3; ++n) expect_refused(std::span(valid.data(), n), "magic");
    expect_refused(Bytes{'T', 'W', 'I', 0x1B, 1, 0}, "magic");

    const std::string png = ::testing::TempDir() + "twi_robustness.png";
    write_image(scene(8, 6), png);
    std::ifstream in(png, std::ios::binary);
    const Bytes png_bytes{std::istreambuf_iterator<char>(in), {}};
    std::filesystem::remove(png);
    ASSERT_GT(png_bytes.size(), 8u);
    expect_refused(png_bytes, "magic");

    std::mt19937_64 rng(7);
    Tally tally{"random bytes"};
    for (int k = 0; k < 200; ++k) {
        Bytes noise(1 + rng() % 300);
        for (uint8_t& b : noise) b = static_cast<uint8_t>(rng());
        if (tally.decode(noise, {}, "random").kind != Outcome::error)
            tally.fail("random", "decoded");
        // The right magic (and every other time the version), then garbage: the CRC if nothing
        // else catches it.
        noise.insert(noise.begin(), valid.begin(), valid.begin() + 4 + k % 2);
        if (tally.decode(noise, {}, "magic + random").kind != Outcome::error)
            tally.fail("magic + random", "decoded");
    }
    tally.report();

    for (uint8_t version : {0, 2, 255}) {
        Bytes other = valid;
        other[4] = version;
        expect_refused(other, "version");
        expect_refused(with_crc(Bytes(other.begin(), other.begin() + header_bytes)), "version");
    }
    Bytes bad_crc = valid;
    bad_crc[header_bytes - 1] ^= 0x40;
    expect_refused(bad_crc, "CRC");
}

// ---- 4. Headers with a valid CRC that claim absurd sizes ----

// A header whose band arrays fit its transform and levels (so that the field under test is what
// gets refused), with a stream of `stream_bytes` bytes.
Bytes header_file(TwiHeader h, size_t stream_bytes = 0, uint8_t planes = 4) {
    const bool sized = h.width > 0 && h.height > 0;
    const size_t bands = sized ? static_cast<size_t>(expected_bands(h)) : 1;
    h.band_norms.resize(bands, 1.0f);
    h.shifts.resize(bands, 0);
    h.channel_factors.resize(h.channels, 1.0f);
    h.planes.assign(h.channels, std::vector<uint8_t>(bands, planes));
    Bytes file = write_twi_header(h);
    for (size_t k = 0; k < stream_bytes; ++k) file.push_back(static_cast<uint8_t>(k * 73 + 5));
    return file;
}

TwiHeader grid_header(TwiTransform t, int w, int h, int levels) {
    TwiHeader header;
    header.transform = t;
    header.width = w;
    header.height = h;
    header.levels = levels;
    return header;
}

TwiHeader mesh_header(int w, int h, int cols, int rows, int levels) {
    TwiHeader header = grid_header(TwiTransform::mesh, w, h, levels);
    header.grid_cols = cols;
    header.grid_rows = rows;
    return header;
}

// Where the mesh fields start: magic, version, flags, transform, colour, channels, depth, width,
// height, levels.
size_t mesh_offset(const TwiHeader& h) {
    return 11 + varint_bytes(h.width).size() + varint_bytes(h.height).size();
}

// The bytes after the mesh fields: base step, channel factors, band count, norms and shifts,
// plane counts, CRC.
size_t tail_size(const TwiHeader& h) {
    const size_t bands = static_cast<size_t>(expected_bands(h)), channels = h.channels;
    return 4 + 4 * channels + varint_bytes(bands).size() + 5 * bands + channels * bands + 4;
}

// A valid explicit-mesh header (placement, kind and counts included) with the mesh fields after
// placement and kind replaced by `mesh_fields`, and the CRC made to match.
Bytes with_mesh_fields(const TwiHeader& explicit_mesh, const Bytes& mesh_fields) {
    const Bytes file = header_file(explicit_mesh);
    const size_t begin = mesh_offset(explicit_mesh) + 2,
                 end = file.size() - tail_size(explicit_mesh);
    EXPECT_EQ(file[begin - 1], 1) << "not an explicit mesh header";
    Bytes out(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(begin));
    out.insert(out.end(), mesh_fields.begin(), mesh_fields.end());
    out.insert(out.end(), file.begin() + static_cast<std::ptrdiff_t>(end), file.end());
    return with_crc(out);
}

TEST(TwiRobustness, headers_claiming_absurd_image_sizes_are_refused) {
    const StillDecodeOptions small{.limits = kSmall};
    expect_refused(header_file(grid_header(TwiTransform::grid53, 1 << 20, 1 << 20, 5)),
                   "exceed the limit");
    expect_refused(header_file(grid_header(TwiTransform::grid97, (1 << 20) + 1, 4, 5)), "width");
    expect_refused(header_file(grid_header(TwiTransform::grid97, 4, 0, 5)), "height");
    expect_refused(header_file(grid_header(TwiTransform::grid53, 1 << 14, 1 << 14, 5)),
                   "exceed the limit", small);
    expect_refused(header_file(grid_header(TwiTransform::grid53, 64, 64, 21)), "too many levels");
    expect_refused(header_file(mesh_header(64, 64, 4, 4, 13)), "too many levels");
    // Only the last decodes: a 1x1 image with 20 levels has one band.
    EXPECT_EQ(decompress_image(header_file(grid_header(TwiTransform::grid53, 1, 1, 20), 9), "t.twi")
                  .width,
              1);
}

TEST(TwiRobustness, headers_claiming_absurd_meshes_are_refused) {
    const StillDecodeOptions small{.limits = kSmall};
    const StillDecodeOptions no_pixel_limit{
        .limits = {.max_pixels = std::numeric_limits<int64_t>::max()}};
    expect_refused(header_file(mesh_header(1'000'000, 1'000'000, 1'000'000, 1'000'000, 1)),
                   "vertex limit", no_pixel_limit);
    expect_refused(header_file(mesh_header(1'000'000, 60, 1'000'000, 60, 1)), "vertex limit");
    expect_refused(header_file(mesh_header(64, 48, 65, 4, 1)), "grid columns");
    expect_refused(header_file(mesh_header(64, 48, 4, 49, 1)), "grid rows");
    expect_refused(header_file(mesh_header(1000, 1000, 100, 100, 12)), "samples");
    expect_refused(header_file(mesh_header(64, 48, 4, 3, 7)), "samples", small);

    TwiHeader aligned = mesh_header(8193, 6145, 2, 2, 12);  // 67M samples
    aligned.placement = MeshPlacement::centres;
    expect_refused(header_file(aligned), "samples");
    aligned = mesh_header(2, 2, 1, 1, 12);  // 17M samples for 4 pixels
    aligned.placement = MeshPlacement::centres;
    expect_refused(header_file(aligned), "samples");
    aligned = mesh_header(65, 33, 4, 2, 4);
    aligned.placement = MeshPlacement::centres;
    EXPECT_EQ(decompress_image(header_file(aligned, 20), "t.twi").width, 65);
    aligned.grid_cols = 5;
    expect_refused(header_file(aligned), "grid size");
    aligned = mesh_header(65, 33, 64, 32, 0);
    aligned.placement = MeshPlacement::centres;
    expect_refused(header_file(aligned), "J >= 1");
    TwiHeader centres_explicit = mesh_header(40, 30, 0, 0, 2);
    centres_explicit.placement = MeshPlacement::centres;
    centres_explicit.mesh = samples::paper_t0(40, 30);
    expect_refused(header_file(centres_explicit), "must be a grid");
}

TEST(TwiRobustness, explicit_mesh_counts_are_checked_against_the_bytes_and_the_limits) {
    TwiHeader h = mesh_header(40, 30, 0, 0, 2);
    h.mesh = samples::paper_t0(40, 30);
    round_mesh_vertices(h.mesh);
    EXPECT_EQ(decompress_image(header_file(h, 30), "t.twi").width, 40);  // the base decodes

    auto fields = [](std::initializer_list<int64_t> signed_values, bool zigzag) {
        ByteWriter w;
        for (int64_t v : signed_values) zigzag ? w.svarint(v) : w.varint(static_cast<uint64_t>(v));
        return w.data();
    };
    // Three vertices, one face of `corner_count` corners with ids 0, 1 and 1 + the last delta,
    // and `feature_count` features (each case fails on a count or id before any validation).
    auto triangle = [](uint64_t face_count, uint64_t corner_count, int64_t last_corner_delta,
                       uint64_t feature_count) {
        ByteWriter w;
        w.varint(3);
        for (int64_t v : {0, 0, 40 * 256, 0, 0, 30 * 256}) w.svarint(v);
        w.varint(face_count);
        w.varint(corner_count);
        for (int64_t d : {int64_t{0}, int64_t{1}, last_corner_delta}) w.svarint(d);
        w.varint(feature_count);
        return w.data();
    };
    const int64_t billion = 1'000'000'000;
    expect_refused(with_mesh_fields(h, fields({billion}, false)), "vertex count");
    expect_refused(with_mesh_fields(h, fields({2}, false)), "vertex count");
    expect_refused(with_mesh_fields(h, fields({int64_t{1} << 62}, false)), "vertex count");
    Bytes million(2'000'010, 0);
    million.insert(million.begin(), {0xC0, 0x84, 0x3D});  // varint 10^6
    expect_refused(with_mesh_fields(h, million), "vertex count",
                   {.limits = {.max_mesh_vertices = 1000}});
    expect_refused(with_mesh_fields(h, fields({3, int64_t{1} << 50, 0}, false)), "out of range");
    expect_refused(with_mesh_fields(h, triangle(billion, 3, 1, 0)), "face count");
    expect_refused(with_mesh_fields(h, triangle(1, billion, 1, 0)), "corner count");
    expect_refused(with_mesh_fields(h, triangle(1, 2, 1, 0)), "corner count");
    expect_refused(with_mesh_fields(h, triangle(1, 3, 5, 0)), "corner id");
    expect_refused(with_mesh_fields(h, triangle(1, 3, -3, 0)), "corner id");
    expect_refused(with_mesh_fields(h, triangle(1, 3, 1, billion)), "feature count");
    Bytes long_varint(11, 0xFF);
    expect_refused(with_mesh_fields(h, long_varint), "varint");

    // A million coincident vertices and one triangle: refused by the validation, promptly.
    million = fields({1'000'000}, false);
    million.resize(million.size() + 2'000'000, 0);
    for (uint8_t b : fields({1, 3}, false)) million.push_back(b);    // one triangle
    for (uint8_t b : fields({0, 1, 1}, true)) million.push_back(b);  // corners 0, 1, 2
    for (uint8_t b : fields({0}, false)) million.push_back(b);       // no features
    expect_refused(with_mesh_fields(h, million), "mesh");

    const size_t at = mesh_offset(h);
    for (auto [offset, value, word] :
         {std::tuple{at, 2, "placement"}, std::tuple{at + 1, 2, "kind"},
          std::tuple{at + 1, 255, "kind"}}) {
        Bytes file = header_file(h);
        file[offset] = static_cast<uint8_t>(value);
        expect_refused(with_crc(file), word);
    }
}

TEST(TwiRobustness, headers_with_bad_fields_are_refused) {
    const TwiHeader base = file_of("grid 5/3, lossy").result.header;
    auto refused = [&](std::string_view word, auto edit) {
        TwiHeader h = base;
        edit(h);
        Bytes file = write_twi_header(h);
        file.insert(file.end(), 50, 0x5A);
        SCOPED_TRACE(word);
        expect_refused(file, word);
    };
    refused("band count", [](TwiHeader& h) {
        h.band_norms.push_back(1);
        h.shifts.push_back(0);
    });
    refused("band count", [](TwiHeader& h) {
        h.band_norms.pop_back();
        h.shifts.pop_back();
        for (auto& c : h.planes) c.pop_back();
    });
    refused("bit-plane count", [](TwiHeader& h) { h.planes[1][2] = 32; });
    refused("bit-plane count", [](TwiHeader& h) { h.planes[0][0] = 255; });
    refused("band shift", [](TwiHeader& h) { h.shifts[3] = 33; });
    refused("base step", [](TwiHeader& h) { h.base_step = 0; });
    refused("base step", [](TwiHeader& h) { h.base_step = -1; });
    refused("base step", [](TwiHeader& h) { h.base_step = std::nanf(""); });
    refused("base step", [](TwiHeader& h) { h.base_step = INFINITY; });
    refused("factor", [](TwiHeader& h) { h.channel_factors[2] = 0; });
    refused("band norm", [](TwiHeader& h) { h.band_norms[1] = -2; });
    refused("band norm", [](TwiHeader& h) { h.band_norms[1] = std::nanf(""); });
    refused("channels", [](TwiHeader& h) { h.channels = 0; });
    refused("channels", [](TwiHeader& h) { h.channels = 5; });
    refused("colour", [](TwiHeader& h) {
        h.channels = 1;
        h.channel_factors.resize(1);
        h.planes.resize(1);
    });
    refused("bit depth", [](TwiHeader& h) { h.bit_depth = 12; });
    refused("transform", [](TwiHeader& h) { h.transform = static_cast<TwiTransform>(3); });
    refused("colour", [](TwiHeader& h) { h.colour = static_cast<TwiColour>(3); });
    Bytes flags = write_twi_header(base);
    flags[5] = 2;
    expect_refused(with_crc(flags), "flags");
}

// ---- 5. A valid header with an invalid mesh ----

TEST(TwiRobustness, an_invalid_explicit_mesh_is_refused) {
    TwiHeader h = mesh_header(40, 30, 0, 0, 2);
    auto refused = [&](const Mesh& mesh, std::string_view word) {
        ASSERT_FALSE(validate(mesh).ok());
        h.mesh = mesh;
        expect_refused(header_file(h, 40), "mesh");
        expect_refused(header_file(h, 40), word);
    };
    // A dart: the face (0, 0), (10, 15), (40, 30), (0, 30) has a reflex corner at (10, 15).
    Mesh dart;
    dart.width = 40;
    dart.height = 30;
    dart.vertices = {{0, 0}, {40, 0}, {40, 30}, {0, 30}, {10, 15}};
    dart.add_face(std::vector<int32_t>{0, 1, 2, 4});
    dart.add_face(std::vector<int32_t>{0, 4, 2, 3});
    refused(dart, "convex");

    Mesh outside = grid_mesh(40, 30, 2, 2);
    outside.vertices[0] = {-1, -1};
    refused(outside, "outside the domain");
    outside.vertices[0] = {0, 0};
    outside.vertices[8] = {41, 30};
    refused(outside, "outside the domain");

    Mesh hole = grid_mesh(40, 30, 3, 3);  // without the middle cell
    std::vector<std::vector<int32_t>> faces;
    for (int f = 0; f < hole.num_faces(); ++f) {
        if (f != 4) faces.emplace_back(hole.face(f).begin(), hole.face(f).end());
    }
    hole.face_offsets = {0};
    hole.face_corners.clear();
    for (const auto& face : faces) hole.add_face(face);
    refused(hole, "gap");

    Mesh reversed = grid_mesh(40, 30, 2, 2);
    std::reverse(reversed.face_corners.begin(), reversed.face_corners.begin() + 4);
    refused(reversed, "face 0");

    Mesh feature = grid_mesh(40, 30, 2, 2);
    feature.features.push_back({0, 8});  // not an edge
    refused(feature, "feature");
}

// ---- Defects these tests found (fixed) ----

// The mesh's vertex coordinates and corner ids are zigzag deltas: adding an unchecked delta such as
// 2^63 - 1 overflowed int64 (UBSan: twi_format.cpp, "signed integer overflow") and std::abs of
// INT64_MIN too. Fixed by checking each delta before adding it.
TEST(TwiRobustness, delta_coded_mesh_fields_cannot_overflow) {
    TwiHeader h = mesh_header(40, 30, 0, 0, 2);
    h.mesh = samples::paper_t0(40, 30);
    const int64_t top = std::numeric_limits<int64_t>::max(), bottom = -top - 1;
    std::vector<Bytes> files;
    for (auto [first, second] : {std::pair{int64_t{1} << 40, top}, std::pair{int64_t{0}, bottom},
                                 std::pair{-(int64_t{1} << 40), bottom}}) {
        ByteWriter w;  // vertex 0 at (first, 0), then a delta of `second` along x
        w.varint(3);
        for (int64_t v : {first, int64_t{0}, second, int64_t{0}}) w.svarint(v);
        files.push_back(with_mesh_fields(h, w.data()));
    }
    for (int64_t delta : {top, bottom}) {
        ByteWriter w;  // a triangle whose second corner is 1 + delta
        w.varint(3);
        for (int64_t v : {0, 0, 40 * 256, 0, 0, 30 * 256}) w.svarint(v);
        w.varint(1);
        w.varint(3);
        for (int64_t v : {int64_t{1}, delta, int64_t{0}}) w.svarint(v);
        w.varint(0);
        files.push_back(with_mesh_fields(h, w.data()));
    }
    expect_error_or_return_in_child([&] {
        for (size_t i = 0; i < files.size(); ++i) {
            if (message_of(files[i]).find("out of range") == std::string::npos) std::_Exit(3 + i);
        }
    });
}

// A lossless header may claim up to 31 bit-planes per band whatever the bit depth, and the stream
// then decodes to coefficients near 2^31. Their int32 inverse overflowed (UBSan, "signed integer
// overflow" at lifting.cpp:56, :53, :65, :68 for the mesh and fixed_grid.cpp:141 for the grid
// 5/3, from StillDomain::inverse_int); such coefficients now take the int64 inverse. Each header
// here has one channel and a 64-byte stream; the test can only fail under -fsanitize=undefined.
TEST(TwiRobustness, lossless_coefficients_near_2_to_31_do_not_overflow_the_integer_inverse) {
    auto lossless = [](TwiHeader h) {
        h.lossless = true;
        return header_file(h, 64, 31);
    };
    TwiHeader aligned = mesh_header(5, 5, 1, 1, 2);
    aligned.placement = MeshPlacement::centres;
    for (const auto& [name, file] :
         {std::pair{"grid 5/3, 2x2, 1 level", lossless(grid_header(TwiTransform::grid53, 2, 2, 1))},
          std::pair{"grid mesh, 16x16, 1 cell, J = 2", lossless(mesh_header(16, 16, 1, 1, 2))},
          std::pair{"aligned mesh, 5x5, 1 cell, J = 2", lossless(aligned)}}) {
        SCOPED_TRACE(str(name, ", ", file.size(), " bytes"));
        expect_error_or_return_in_child([&] { decompress_image(file, "t.twi"); });
    }
}

// Header-only files of 130 to 180 bytes could describe, within the default limits of the time,
// images whose decoding took gigabytes (at -O3): a 16384x16384 grid 5/3 image (2^28 pixels)
// passed 15 GB in 44 s, a 2x2 image on pixel centres at J = 12 (16.8M mesh samples for 4 pixels)
// took 4.4 GB, a 2x1 grid mesh at J = 12 8.4 GB. The limits are now 2^26 pixels and 20 samples
// a pixel. Each runs in a child whose address space may grow by 1 GB only (std::bad_alloc fails
// the test); skipped under ASan, which reserves terabytes of address space.
TEST(TwiRobustness, a_tiny_header_cannot_make_the_decoder_allocate_gigabytes) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "address-space limits do not work under AddressSanitizer";
#endif
    TwiHeader aligned = mesh_header(2, 2, 1, 1, 12);
    aligned.placement = MeshPlacement::centres;
    for (const auto& [name, file] :
         {std::pair{"grid 5/3, 16384x16384",
                    header_file(grid_header(TwiTransform::grid53, 1 << 14, 1 << 14, 5))},
          std::pair{"aligned mesh, 2x2, J = 12", header_file(aligned)},
          std::pair{"grid mesh 2x1, J = 12", header_file(mesh_header(2, 1, 2, 1, 12))}}) {
        SCOPED_TRACE(str(name, ", ", file.size(), " bytes"));
        expect_error_or_return_in_child([&] {
            size_t pages = 0;
            std::ifstream("/proc/self/statm") >> pages;
            const rlim_t cap =
                pages * static_cast<size_t>(sysconf(_SC_PAGESIZE)) + (size_t{1} << 30);
            const rlimit limit{cap, cap};
            setrlimit(RLIMIT_AS, &limit);
            try {
                decompress_image(file, "t.twi");
            } catch (const std::bad_alloc&) {
                std::fprintf(stderr, "the decoder needed more than 1 GB\n");
                std::_Exit(4);
            }
        });
    }
}

}  // namespace
}  // namespace tesswave
