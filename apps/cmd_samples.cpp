// tesswave samples: writes the procedural sample images and meshes the project generates itself.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "cli.h"
#include "core/io/file_io.h"
#include "core/io/image_io.h"
#include "core/io/mesh_io.h"
#include "core/io/video_io.h"
#include "core/math/error.h"
#include "core/math/strings.h"
#include "samples/sample_clip.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"
#include "samples/sample_pair.h"

namespace tesswave::cli {

std::vector<std::string> write_samples(const std::string& dir, int width, int height) {
    namespace fs = std::filesystem;
    std::vector<std::string> written;
    auto out = [&](const std::string& name) {
        written.push_back((fs::path(dir) / name).string());
        return written.back();
    };
    Image scene = samples::scene_image(width, height);
    write_image(scene, out("scene.png"));
    Image grey = make_image(width, height, 1);
    for (size_t i = 0; i < grey.planes[0].size(); ++i) {
        grey.planes[0][i] =
            0.299f * scene.planes[0][i] + 0.587f * scene.planes[1][i] + 0.114f * scene.planes[2][i];
    }
    write_image(grey, out("scene_grey.png"));
    Image deep = scene;
    deep.format = SampleFormat::u16;
    write_image(deep, out("scene_16bit.tif"));
    Image rgba = scene;
    rgba.planes.push_back(std::vector<float>(scene.planes[0].size()));
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) rgba.at(3, x, y) = 0.25f + 0.75f * x / (width - 1.0f);
    }
    write_image(rgba, out("scene_rgba.png"));
    write_mesh(samples::paper_t0(width, height), out("paper_t0.json"));
    write_mesh(samples::paper_t0_with_features(width, height), out("paper_features.json"));
    // A morph pair with a known deformation, its point files and the true middle frame.
    const samples::SamplePair pair = samples::deformed_pair(width, height, 60);
    write_image(pair.a, out("pair_a.png"));
    write_image(pair.b, out("pair_b.png"));
    write_image(samples::moved(pair.a, pair.deformation, 0.5), out("pair_middle_truth.png"));
    for (const auto& [points, name] :
         {std::pair{&pair.points_a, "pair_a.txt"}, std::pair{&pair.points_b, "pair_b.txt"}}) {
        std::string text =
            "# x y, pixels; line i of pair_a.txt corresponds to line i of pair_b.txt\n";
        for (const Vec2& p : *points) text += str(p.x, " ", p.y, "\n");
        write_file_atomic(out(name), text);
    }
    // A clip with known motion: a pan and a slow zoom over a procedural scene, plus a moving
    // disk; lossless FFV1, so that codecs see exactly the generated frames.
    const samples::SampleClipOptions clip{
        .width = 176, .height = 144, .frames = 48, .pan = {1.25, 0.5}, .zoom = 0.002};
    VideoWriter writer(out("clip.mkv"), clip.width, clip.height,
                       {.fps = clip.fps, .codec = VideoCodec::ffv1});
    for (int t = 0; t < clip.frames; ++t) writer.write(samples::sample_clip_frame(clip, t));
    writer.finish();
    return written;
}

void add_samples_command(CLI::App& app) {
    struct Args {
        std::string dir;
        std::string size = "249x251";
        bool overwrite = false;
    };
    auto args = std::make_shared<Args>();
    auto* cmd = app.add_subcommand("samples",
                                   "Write the procedural sample images (RGB, grey, 16-bit, RGBA), "
                                   "meshes, morph pair and clip");
    cmd->add_option("-o,--output", args->dir, "Output folder")->required();
    cmd->add_option("--size", args->size, "Image size WxH (the paper's is 249x251)")
        ->capture_default_str();
    cmd->add_flag("-y,--overwrite", args->overwrite, "Overwrite files in a non-empty folder");
    cmd->callback([args] {
        auto [w, h] = parse_size(args->size, "--size");
        if (w != static_cast<int>(w) || h != static_cast<int>(h) || w < 2 || h < 2 || w * h > 1e8) {
            throw Error("--size: need whole pixel counts from 2x2 up to 1e8 pixels");
        }
        prepare_folder(args->dir, args->overwrite);
        for (const auto& f : write_samples(args->dir, static_cast<int>(w), static_cast<int>(h))) {
            std::printf("%s\n", f.c_str());
        }
    });
}

}  // namespace tesswave::cli
