// Procedural, natural-looking sample images the project generates itself: smooth shading,
// hard edges, texture, text-like detail and colour. Deterministic for a given seed.
#pragma once

#include <cstdint>

#include "core/math/image.h"

namespace tesswave::samples {

// An RGB landscape-like scene: sky gradient, sun disc, hills with soft shading, a textured field,
// a house-like block with sharp edges and rows of glyph-like marks. Values in [0,1].
Image scene_image(int width, int height, uint64_t seed = 1);

// RGB noise, every value independent (a linear congruential generator from seed 12345): what no
// wavelet compresses and every sample's place shows in. Values in [0,1).
Image noise_image(int width, int height);

}  // namespace tesswave::samples
