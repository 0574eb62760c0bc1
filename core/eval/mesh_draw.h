// Pictures of a tessellation and its refinement (the paper's Figure 1): T0 bold, the refinement
// levels thin, feature edges highlighted, optionally over an image.
#pragma once

#include <optional>
#include <string>

#include "core/math/hierarchy.h"
#include "core/math/image.h"
#include "core/math/mesh.h"

namespace tesswave {

struct DrawOptions {
    int levels = 2;           // refinement levels drawn thin (T_1..T_levels)
    double scale = 0.0;       // output pixels per domain unit; 0: fit the long side to ~1024 px
    double line_width = 1.0;  // of the thin lines; T0 is drawn 2.5x as wide
};

// An RGB raster (planar floats in [0,1]) of the mesh, over `background` when given (it is
// resized to the output size). Throws Error for invalid meshes or absurd sizes.
Image draw_mesh(const Mesh& mesh, const DrawOptions& options, const Image* background = nullptr);

// The most refinement levels, at most `most`, that a picture at `scale` (0: the default) can show:
// draw_mesh refuses a level with more edges than twice the picture's pixels.
int drawable_levels(const Mesh& mesh, int most, double scale = 0.0);

// The same picture as SVG; `background_href` (a path or URL) is placed under the lines.
std::string draw_mesh_svg(const Mesh& mesh, const DrawOptions& options,
                          const std::string& background_href = "");

}  // namespace tesswave
