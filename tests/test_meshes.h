// Small procedural meshes shared by the tests; each one is validated before use.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/validate.h"

namespace tesswave::testing {

// Uniform double in [0,1) from raw engine output (the std distributions differ between
// standard libraries; these tests must be identical everywhere).
inline double uniform(std::mt19937_64& rng) { return (rng() >> 11) * 0x1.0p-53; }

// A grid mesh whose interior vertices are moved at random by up to `amount` of a cell, which
// keeps every cell convex for amount < 0.25.
inline Mesh deformed_grid(double width, double height, int cols, int rows, double amount,
                          uint64_t seed) {
    Mesh mesh = grid_mesh(width, height, cols, rows);
    std::mt19937_64 rng(seed);
    for (int j = 1; j < rows; ++j) {
        for (int i = 1; i < cols; ++i) {
            Vec2& p = mesh.vertices[j * (cols + 1) + i];
            p.x += (uniform(rng) - 0.5) * 2 * amount * width / cols;
            p.y += (uniform(rng) - 0.5) * 2 * amount * height / rows;
        }
    }
    return mesh;
}

// The message of the tesswave::Error that `call` throws, or "(no error)".
inline std::string error_of(auto&& call) {
    try {
        call();
    } catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

inline void expect_valid(const Mesh& mesh) {
    ValidationReport report = validate(mesh);
    ASSERT_TRUE(report.ok()) << report.problems.front();
}

}  // namespace tesswave::testing
