// libFuzzer target: arbitrary bytes as a point list, through parse_points -> triangulate_points in
// a 100 x 100 domain -> validate. tesswave::Error is the only acceptable exception; a triangulation
// that is returned but invalid, or that does not keep the given points first, aborts. Build with
// clang's -fsanitize=fuzzer, or with fuzz_driver.cpp to replay inputs with any compiler.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "core/io/mesh_io.h"
#include "core/math/error.h"
#include "core/math/triangulate.h"
#include "core/math/validate.h"
#include "fuzz_check.h"

namespace {

using namespace tesswave;

[[noreturn]] void fail(const char* what) { fuzz::fail("points_fuzz", what); }
void check_message(const Error& e) { fuzz::check_message("points_fuzz", e); }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    try {
        const std::vector<Vec2> points = parse_points(text, "fuzz.txt");
        // The input's length picks the border option, so the corpus explores all three.
        const int border = static_cast<int>(size % 3);
        const Mesh mesh = triangulate_points(100, 100, points, {.border_points_per_side = border});
        if (!validate(mesh).ok()) fail("triangulate_points returned an invalid mesh");
        if (mesh.vertices.size() < points.size()) fail("triangulate_points lost points");
        for (size_t i = 0; i < points.size(); ++i) {
            if (!(mesh.vertices[i] == points[i])) fail("vertex i is not point i");
        }
    } catch (const Error& e) {
        check_message(e);
    }
    return 0;
}
