#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/metrics.h"
#include "core/math/validate.h"
#include "morph/auto_match.h"
#include "morph/faces.h"
#include "morph/inbetween.h"
#include "morph/morph.h"
#include "morph/pair.h"
#include "samples/sample_images.h"
#include "samples/sample_pair.h"
#include "test_meshes.h"

namespace tesswave::morph {
namespace {

using testing::error_of;

TEST(MorphPair, bad_correspondences_are_refused_with_the_file_and_point) {
    const Correspondences ok{{{1, 1}, {10, 2}, {5, 9}}, {{2, 1}, {11, 3}, {4, 8}}};
    EXPECT_NO_THROW(check_correspondences(ok, 20, 20, 20, 20, "a.txt", "b.txt"));
    Correspondences c = ok;
    c.b.pop_back();
    EXPECT_NE(error_of([&] {
                  check_correspondences(c, 20, 20, 20, 20, "a.txt", "b.txt");
              }).find("same count"),
              std::string::npos);
    c = ok;
    c.a[1] = {NAN, 2};
    EXPECT_NE(error_of([&] {
                  check_correspondences(c, 20, 20, 20, 20, "a.txt", "b.txt");
              }).find("a.txt: point 2"),
              std::string::npos);
    c = ok;
    c.b[2] = {25, 8};
    EXPECT_NE(error_of([&] {
                  check_correspondences(c, 20, 20, 20, 20, "a.txt", "b.txt");
              }).find("outside"),
              std::string::npos);
    c = ok;
    c.a[2] = c.a[0];
    EXPECT_NE(error_of([&] {
                  check_correspondences(c, 20, 20, 20, 20, "a.txt", "b.txt");
              }).find("same point"),
              std::string::npos);
    c = {{{1, 1}, {2, 2}}, {{1, 1}, {2, 2}}};
    EXPECT_NE(error_of([&] {
                  check_correspondences(c, 20, 20, 20, 20, "a.txt", "b.txt");
              }).find("at least 3"),
              std::string::npos);
}

TEST(MorphPair, triangle_files) {
    EXPECT_EQ(parse_triangles("# t\n0 1 2\n\n2 3 0 # x\n", 4, "t.txt").size(), 2u);
    EXPECT_EQ(parse_triangles("\xEF\xBB\xBF"
                              "0 1 2\n",
                              4, "bom.txt")
                  .size(),
              1u);  // a UTF-8 BOM
    EXPECT_NE(error_of([] { parse_triangles("0 1\n", 4, "t.txt"); }).find("t.txt:1"),
              std::string::npos);
    EXPECT_NE(error_of([] { parse_triangles("0 1 9\n", 4, "t.txt"); }).find("outside"),
              std::string::npos);
    EXPECT_THROW(parse_triangles("0 1 1\n", 4, "t.txt"), Error);
    EXPECT_THROW(parse_triangles("# nothing\n", 4, "t.txt"), Error);
    // Overlapping or hole-leaving triangles are refused when the pair is built.
    const Correspondences square{{{0, 0}, {10, 0}, {10, 10}, {0, 10}},
                                 {{0, 0}, {10, 0}, {10, 10}, {0, 10}}};
    EXPECT_NO_THROW(triangles_pair(square, {{0, 1, 2}, {0, 2, 3}}, 10, 10, 10, 10));
    EXPECT_THROW(triangles_pair(square, {{0, 1, 2}}, 10, 10, 10, 10), Error);  // a hole
    EXPECT_THROW(triangles_pair(square, {{0, 1, 2}, {0, 2, 3}, {1, 2, 3}}, 10, 10, 10, 10),
                 Error);  // overlap
}

TEST(MorphPair, triangulated_pair_shares_topology_and_leaves_out_crossings) {
    const samples::SamplePair p = samples::deformed_pair(160, 120, 40);
    const PairMeshes pair = triangulated_pair({p.points_a, p.points_b}, 160, 120, 160, 120);
    EXPECT_EQ(pair.a.face_corners, pair.b.face_corners);
    EXPECT_TRUE(pair.dropped.empty());
    EXPECT_EQ(pair.repair, "");
    // Two swapped points cross: the fewest points are left out (one or both of the two), said in
    // one line, and what remains is valid in both images.
    Correspondences crossed{p.points_a, p.points_b};
    std::swap(crossed.b[3], crossed.b[30]);
    const PairMeshes mended = triangulated_pair(crossed, 160, 120, 160, 120);
    ASSERT_FALSE(mended.dropped.empty());
    EXPECT_LE(mended.dropped.size(), 2u);
    for (int i : mended.dropped) EXPECT_TRUE(i == 3 || i == 30) << i;
    EXPECT_NE(mended.repair.find("fold"), std::string::npos) << mended.repair;
    EXPECT_EQ(mended.repair.find('\n'), std::string::npos);
    EXPECT_TRUE(validate(mended.a).ok());
    EXPECT_TRUE(validate(mended.b).ok());
    EXPECT_EQ(mended.a.num_vertices(), pair.a.num_vertices() - mended.dropped.size());
    // Different image sizes: the border maps to the border.
    std::vector<Vec2> scaled = p.points_b;
    for (Vec2& q : scaled) q = 1.5 * q;
    const PairMeshes big = triangulated_pair({p.points_a, scaled}, 160, 120, 240, 180);
    EXPECT_EQ(big.b.width, 240);
    EXPECT_EQ(big.b.vertices.back().x == 0 || big.b.vertices.back().x == 240 ||
                  big.b.vertices.back().y == 0 || big.b.vertices.back().y == 180,
              true);
}

// Hostile landmark pairs: random points in A and unrelated random points in B (most triangles
// fold), some on the border, some repeated in the mean shape. Every pair either gives meshes
// valid in both images, without the points it says it left out, or an Error; never a hang.
TEST(MorphPair, triangulated_pair_survives_random_correspondences) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> x(0, 100), y(0, 80);
    int valid = 0;
    for (int trial = 0; trial < 200; ++trial) {
        Correspondences c;
        const int n = 3 + static_cast<int>(rng() % 40);
        for (int i = 0; i < n; ++i) {
            Vec2 a{std::round(x(rng)), std::round(y(rng))}, b{x(rng), y(rng)};
            if (rng() % 8 == 0) a.x = b.x = 0;          // on the left side in both
            if (rng() % 16 == 0) b = {100 - a.x, a.y};  // mirrored: crossing
            c.a.push_back(a);
            c.b.push_back(b);
        }
        try {
            check_correspondences(c, 100, 80, 100, 80, "a.txt", "b.txt");
        } catch (const Error&) {
            continue;  // duplicates within an image: refused before any mesh
        }
        try {
            const PairMeshes pair = triangulated_pair(c, 100, 80, 100, 80);
            ASSERT_TRUE(validate(pair.a).ok()) << trial;
            ASSERT_TRUE(validate(pair.b).ok()) << trial;
            EXPECT_EQ(pair.a.num_vertices(), pair.b.num_vertices());
            EXPECT_GE(static_cast<int>(c.a.size() - pair.dropped.size()), 3) << trial;
            ++valid;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()), "") << trial;
        }
    }
    EXPECT_GT(valid, 100);  // most pairs are mended, not refused
}

// Landmark files carry their own border points (face tools add the corners and side midpoints),
// which move along a side between the images: none is left out, and the mesh's own border points
// keep off the stretch they span. A point on the border in one image only is left out.
TEST(MorphPair, triangulated_pair_takes_border_landmarks) {
    Correspondences c{{{40, 30}, {120, 30}, {80, 90}, {160, 50}, {0, 0}, {0, 120}, {160, 120}},
                      {{45, 35}, {110, 28}, {85, 95}, {160, 85}, {0, 0}, {0, 120}, {160, 120}}};
    const PairMeshes pair = triangulated_pair(c, 160, 120, 160, 120);
    EXPECT_TRUE(pair.dropped.empty()) << pair.repair;
    EXPECT_TRUE(validate(pair.b).ok());
    c.b[3] = {150, 85};  // inside B, on A's right side
    const PairMeshes off = triangulated_pair(c, 160, 120, 160, 120);
    EXPECT_EQ(off.dropped, std::vector<int>{3});
    EXPECT_NE(off.repair.find("border in one image only"), std::string::npos) << off.repair;
}

// On the procedural pair with a known deformation, the fitted mesh follows the truth to < 0.5 px
// RMS, the middle frame beats 35 dB against the known in-between with the mesh alone, and with
// point sampling the residual warp adds at least 1 dB more (it removes most of the resampling
// loss). The projection, with the mesh alone, also gains at least 1 dB over point sampling. All on
// the linear schedule: the truth is the warp and dissolve of one picture.
void expect_recovered(const samples::SamplePair& p, const PairMeshes& pair) {
    const Schedule linear{.kind = ScheduleKind::linear};
    double sq = 0;
    for (size_t i = 0; i < pair.a.vertices.size(); ++i) {
        const Vec2 e = pair.b.vertices[i] - p.deformation.at(pair.a.vertices[i], 1.0);
        sq += dot(e, e);
    }
    EXPECT_LT(std::sqrt(sq / pair.a.vertices.size()), 0.5);
    const Image truth = samples::moved(p.a, p.deformation, 0.5);
    const MorphOptions mesh_only{
        .density = 2.0, .schedule = linear, .residual = false, .sampling = Sampling::point};
    const double mesh = psnr(truth, Morph(p.a, p.b, pair.a, pair.b, mesh_only).frame(0.5)).all;
    const MorphOptions point{
        .density = 2.0, .schedule = linear, .residual = true, .sampling = Sampling::point};
    const double full = psnr(truth, Morph(p.a, p.b, pair.a, pair.b, point).frame(0.5)).all;
    EXPECT_GT(mesh, 35.0);
    EXPECT_GT(full, mesh + 1.0);
    const MorphOptions fit{
        .density = 2.0, .schedule = linear, .residual = false, .sampling = Sampling::fit};
    const double fitted = psnr(truth, Morph(p.a, p.b, pair.a, pair.b, fit).frame(0.5)).all;
    EXPECT_GT(fitted, mesh + 1.0) << "fit " << fitted << " dB, point " << mesh << " dB";
}

TEST(MorphPair, known_deformation_is_recovered_from_given_points) {
    const samples::SamplePair p = samples::deformed_pair(320, 240, 600);
    expect_recovered(p,
                     fitted_pair(grid_mesh(320, 240, 16, 12), {p.points_a, p.points_b}, 320, 240));
}

// The same with correspondences found automatically (--auto): dense flow and features.
TEST(MorphPair, known_deformation_is_recovered_from_automatic_correspondences) {
    const samples::SamplePair p = samples::deformed_pair(320, 240, 10);
    const Matches m = auto_match(p.a, p.b);
    expect_recovered(p, fitted_pair(grid_mesh(320, 240, 16, 12), {m.a, m.b}, 320, 240));
}

// `scene` with a textured disk of radius 5.5 px centred at (cx, cy) in front.
Image with_disk(const Image& scene, double cx, double cy) {
    Image im = scene;
    for (int y = 0; y < im.height; ++y) {
        for (int x = 0; x < im.width; ++x) {
            const double d = std::hypot(x + 0.5 - cx, y + 0.5 - cy);
            const float cover = static_cast<float>(std::clamp(5.5 - d, 0.0, 1.0));
            for (int c = 0; c < 3; ++c) {
                const float ring = c == 1 && d < 2.5 ? 0.0f : 1.0f;  // a textured disk
                im.at(c, x, y) += cover * (ring - im.at(c, x, y));
            }
        }
    }
    return im;
}

// The w x h window of an RGB image at (x0, y0).
Image window(const Image& im, int x0, int y0, int w, int h) {
    Image out = make_image(w, h, 3);
    for (int c = 0; c < 3; ++c) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) out.at(c, x, y) = im.at(c, x0 + x, y0 + y);
        }
    }
    return out;
}

// PSNR of the w x h windows at (x0, y0) of two RGB images.
double window_psnr(const Image& a, const Image& b, int x0, int y0, int w, int h) {
    return psnr(window(a, x0, y0, w, h), window(b, x0, y0, w, h)).all;
}

// A small disk moving fast over a still scene. The fitted grid follows the disk but drags the
// still ground around it (the sun doubles, the hill smears): the mesh's two warps disagree there,
// and the flow fallback mends it: the whole frame gains at least 5 dB against the truth (measured
// with the default 20 px cells: 28.9 -> 40.0 dB), and around the disk, which the flow alone would
// lose, it costs at most 1 dB (there the fast objects gain: 34.3 -> 47.7 dB).
TEST(Inbetween, flow_fallback_mends_the_mesh_where_its_warps_disagree) {
    const int W = 160, H = 120;
    const Image scene = samples::scene_image(W, H, 3);
    const Image f0 = with_disk(scene, 60, 50), f1 = with_disk(scene, 76, 58),
                truth = with_disk(scene, 68, 54);
    InbetweenOptions plain;
    plain.flow_fallback = false;
    const Image without = inbetween(f0, f1, 0.5, plain), with = inbetween(f0, f1, 0.5);
    EXPECT_GT(psnr(truth, with).all, psnr(truth, without).all + 5.0);
    const double near_without = window_psnr(truth, without, 48, 38, 40, 32);
    const double near_with = window_psnr(truth, with, 48, 38, 40, 32);
    EXPECT_GT(near_with, near_without - 1.0) << near_with << " vs " << near_without;
    const double far_without = window_psnr(truth, without, 100, 70, 56, 46);
    const double far_with = window_psnr(truth, with, 100, 70, 56, 46);
    EXPECT_GT(far_with, far_without - 0.5) << far_with << " vs " << far_without;
}

// A small disk thrown across a still scene, further between the frames than the dense flow can
// follow (32 px at 320x240, 11 px across). Without the fast-object stage, the frame shows the
// disk faintly at both ends and not in the middle; with it, the disk is in the middle and the
// ends show the ground. Measured: the middle window 18.2 -> 58.4 dB, the whole frame 38.5 ->
// 70.0 dB.
TEST(Inbetween, a_small_fast_object_is_carried_to_the_middle) {
    const int W = 320, H = 240;
    const Image scene = samples::scene_image(W, H, 3);
    const Image f0 = with_disk(scene, 150, 110), f1 = with_disk(scene, 180, 122),
                truth = with_disk(scene, 165, 116);
    InbetweenOptions plain;
    plain.fast_objects = false;
    const Image without = inbetween(f0, f1, 0.5, plain), with = inbetween(f0, f1, 0.5);
    const double middle_without = window_psnr(truth, without, 153, 104, 24, 24);
    const double middle_with = window_psnr(truth, with, 153, 104, 24, 24);
    const double all_without = psnr(truth, without).all, all_with = psnr(truth, with).all;
    EXPECT_GT(middle_with, middle_without + 10.0);
    EXPECT_GT(all_with, all_without + 6.0);
}

// The same throw on a smaller, plainer scene: too few correspondences for any mesh to fit (the
// disk's own features outvote the ground's). inbetween keeps the mesh at rest, says so, and the
// flow and the fast objects still put the disk in the middle (measured 65.2 dB around it).
TEST(Inbetween, when_no_mesh_fits_the_flow_and_fast_objects_make_the_frame) {
    const Image scene = samples::scene_image(160, 120, 3);
    const Image f0 = with_disk(scene, 60, 50), f1 = with_disk(scene, 90, 60),
                truth = with_disk(scene, 75, 55);
    EXPECT_THROW(automatic_pair(f0, f1, 10), Error);
    std::string note;
    const Image frame = inbetween(f0, f1, 0.5, {}, &note);
    EXPECT_NE(note.find("; the mesh stays at rest"), std::string::npos) << note;
    EXPECT_GT(window_psnr(truth, frame, 63, 43, 24, 24), 30.0);
}

// Face landmarks: a procedural picture holds no face (nothing, not an error); a build without
// dlib or its model says what is missing instead.
TEST(MorphFaces, no_face_in_a_procedural_image) {
    const samples::SamplePair p = samples::deformed_pair(160, 120, 40);
    if (faces_available()) {
        EXPECT_FALSE(find_face(p.a).has_value());
        EXPECT_EQ(faces_missing(), "");
    } else {
        EXPECT_THROW(find_face(p.a), Error);
        EXPECT_NE(faces_missing().find("dlib"), std::string::npos);
    }
}

}  // namespace
}  // namespace tesswave::morph
