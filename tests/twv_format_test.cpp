// The .twv group and frame chunks' fields (video/twv_format.h): the canvas and its windows, and
// the mesh wavelet, read back and refused outside their limits. Whole files, cut and flipped:
// twv_robustness_test.cpp.
#include "video/twv_format.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "core/math/error.h"

namespace tesswave::video {
namespace {

using Bytes = std::vector<uint8_t>;

// A canvas (a panning group's T0 beyond the frame) is at most twice the frame a side, only in
// lifted groups, its grid no finer than a pixel, and each frame's window lies on it.
TEST(TwvRobustness, CanvasesAndWindowsOutsideTheirLimitsAreRefused) {
    const TwvHeader header{.width = 32, .height = 24, .version = 4};
    TwvGroup g{.transform = TwiTransform::mesh,
               .levels = 2,
               .motion = TwvMotion::tracked,
               .grid_cols = 5,
               .grid_rows = 3,
               .channel_factors = {1, 1, 1},
               .lifted = 4,
               .extend_x = 8};
    g.band_norms.assign(twv_band_count(g, header), 1.0f);
    const auto read_group = [&](const TwvGroup& group) {
        return read_twv_group(write_twv_group(group), header, "g");
    };
    const TwvGroup back = read_group(g);
    EXPECT_EQ(back.extend_x, 8);
    EXPECT_EQ(back.extend_y, 0);
    EXPECT_EQ(back.grid_cols, 5);
    TwvFrame f{.number = 0, .kind = TwvFrameKind::band, .window_x = 32, .window_y = 0};
    f.planes.assign(3, std::vector<uint8_t>(g.band_norms.size(), 0));
    const TwvFrame frame_back = read_twv_frame(write_twv_frame(f, g), g, header, "f");
    EXPECT_EQ(frame_back.window_x, 32);

    const auto refused = [&](const TwvGroup& group, const char* why) {
        try {
            read_group(group);
            ADD_FAILURE() << "accepted " << why;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
        }
    };
    TwvGroup wide = g;
    wide.extend_x = 33;
    refused(wide, "canvas extension x");
    TwvGroup low_delay = g;
    low_delay.lifted = 0;
    refused(low_delay, "a canvas in a low-delay group");
    TwvGroup fine = g;
    fine.grid_cols = 41;
    refused(fine, "a grid of 41x3 cells on 40x24 pixels");
    // A version 2 file has no canvas fields: the group's extra bytes are refused.
    EXPECT_THROW(read_twv_group(write_twv_group(g), {.width = 32, .height = 24, .version = 2}, "g"),
                 Error);

    TwvFrame outside = f;
    outside.window_x = 33;  // the canvas is 8 pixels wider: windows up to 32 quarter pixels
    EXPECT_THROW(read_twv_frame(write_twv_frame(outside, g), g, header, "f"), Error);
    outside = f;
    outside.window_y = 1;  // no room down
    EXPECT_THROW(read_twv_frame(write_twv_frame(outside, g), g, header, "f"), Error);
}

// Version 4: a mesh group names its wavelet (0 lifted, 1 the 9/7 on the lattice), whose band
// count follows; other values, and the byte in an earlier version's group, are refused.
TEST(TwvRobustness, TheMeshWaveletIsReadBackAndChecked) {
    const TwvHeader header{.width = 32, .height = 24};
    TwvGroup g{.transform = TwiTransform::mesh,
               .levels = 2,
               .motion = TwvMotion::tracked,
               .grid_cols = 5,
               .grid_rows = 3,
               .mesh_wavelet = MeshWavelet::lattice97,
               .channel_factors = {1, 1, 1},
               .lifted = 4};
    EXPECT_EQ(twv_band_count(g, header), 1 + 3 * 2);
    g.band_norms.assign(twv_band_count(g, header), 1.0f);
    Bytes bytes = write_twv_group(g);
    EXPECT_EQ(read_twv_group(bytes, header, "g").mesh_wavelet, MeshWavelet::lattice97);
    // The lifted wavelet's 1 + 2 J bands do not match the lattice's.
    TwvGroup lifted = g;
    lifted.mesh_wavelet = MeshWavelet::lifted;
    EXPECT_THROW(read_twv_group(write_twv_group(lifted), header, "g"), Error);
    lifted.band_norms.assign(twv_band_count(lifted, header), 1.0f);
    EXPECT_EQ(read_twv_group(write_twv_group(lifted), header, "g").mesh_wavelet,
              MeshWavelet::lifted);
    // The wavelet byte follows the grid's columns and rows (two one-byte varints); 2 is refused
    // as such (a lifted group's band count, so that only the byte is wrong).
    Bytes lifted_bytes = write_twv_group(lifted);
    const size_t at = 1 + 1 + 1 + 1 + 2;
    ASSERT_EQ(lifted_bytes[at], 0);
    lifted_bytes[at] = 2;
    try {
        read_twv_group(lifted_bytes, header, "g");
        ADD_FAILURE() << "accepted mesh wavelet 2";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("mesh wavelet"), std::string::npos) << e.what();
    }
    EXPECT_THROW(read_twv_group(write_twv_group(g), {.width = 32, .height = 24, .version = 3}, "g"),
                 Error);
}

}  // namespace
}  // namespace tesswave::video
