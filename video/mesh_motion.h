// Vertex motion as side information (DESIGN.md 4): a frame's T0 vertex positions on a 1/4-pixel
// grid, coded as velocities (the step from the previous frame). Each velocity is predicted by the
// median of the vertex's own last velocity (0 at the start of a group) and the velocities of two
// mesh neighbours coded before it in this frame, so a pan or a smooth motion leaves residuals
// near zero; the integer residuals are range coded: a zero flag in the context of the previous
// residual on that axis, then sign and Exp-Golomb magnitude with adaptive models.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/mesh.h"

namespace tesswave::video {

inline constexpr double kMotionUnit = 4.0;  // positions are multiples of 1/4 pixel

// Rounds positions to the motion grid.
std::vector<Vec2> round_to_motion_unit(std::span<const Vec2> positions);

// `mesh`: the topology (T0 at rest). `previous` and `current` on the motion grid; `before` is
// empty or the frame before `previous`.
std::vector<uint8_t> encode_motion(const Mesh& mesh, std::span<const Vec2> current,
                                   std::span<const Vec2> previous, std::span<const Vec2> before);

// The inverse. Throws Error (prefixed by `what`) for a truncated stream, positions outside
// [0,W]x[0,H], or positions that do not make `mesh` valid.
// `fast_start`: the models learn fast while fresh (version 2 files and later; range_coder.h).
std::vector<Vec2> decode_motion(std::span<const uint8_t> bytes, std::span<const Vec2> previous,
                                std::span<const Vec2> before, const Mesh& mesh,
                                const std::string& what, bool fast_start = true);

}  // namespace tesswave::video
