// What the morph commands share (cmd_morph.cpp, cmd_compare_morph.cpp): their options and the
// correspondences and mesh pair they build from them.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "cli.h"
#include "core/math/image.h"
#include "core/math/progress.h"
#include "morph/pair.h"

namespace tesswave::cli {

struct MorphArgs {
    std::string a, b, output, points_a, points_b, triangles, mesh, schedule = "aware", bands,
                                                                   schedule_file, shape, size;
    bool automatic = false, faces = false, preview = false, overwrite = false, json = false,
         loop = false;
    int frames = 30, levels = 0;
    H264Settings h264;
    double fps = 25, at = -1, density = 2.0;
    std::string sampling = "point";  // MorphOptions says why
};

// The points of a morph. `landmarks`: face landmarks or point files, which the mean-shape
// triangulation takes; otherwise dense matches, which a fitted grid takes.
struct Points {
    morph::Correspondences c;
    bool landmarks = true;
};

// The correspondences of A and B: point files, or with --auto face landmarks when both images
// hold a face (or --faces), else flow and features. Notes go to `report` and stderr.
Points correspondences(const MorphArgs& a, const Image& ia, const Image& ib, nlohmann::json& report,
                       const Progress& progress);

// The meshes of A and B over the points: --triangles, a triangulation of the mean shape, or a
// mesh fitted to them (--mesh; by default a triangulation of landmarks, a grid for matches).
morph::PairMeshes pair_meshes(const MorphArgs& a, const Points& p, const Image& ia,
                              const Image& ib);

// compare-morph, registered by add_morph_commands between morph and inbetween.
void add_compare_morph_command(CLI::App& app);

}  // namespace tesswave::cli
