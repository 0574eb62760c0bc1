// libFuzzer target: arbitrary bytes as a mesh file, through parse_mesh -> validate -> (valid)
// build_hierarchy at levels 0..2 and float and integer transform round trips, or (invalid) the
// refusal of require_valid and build_hierarchy. tesswave::Error is the only acceptable exception;
// anything else escapes and is reported, and a wrong result aborts. Build with clang's
// -fsanitize=fuzzer, or with fuzz_driver.cpp to replay inputs with any compiler.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <string_view>
#include <vector>

#include "core/io/mesh_io.h"
#include "core/math/error.h"
#include "core/math/hierarchy.h"
#include "core/math/lifting.h"
#include "core/math/validate.h"
#include "fuzz_check.h"

namespace {

using namespace tesswave;

[[noreturn]] void fail(const char* what) { fuzz::fail("mesh_fuzz", what); }
void check_message(const Error& e) { fuzz::check_message("mesh_fuzz", e); }

void round_trips(const Mesh& mesh) {
    for (int J = 0; J <= 2; ++J) {
        // A small sample limit keeps every run fast; bigger meshes stop here with an Error.
        const Hierarchy h = build_hierarchy(mesh, {.levels = J, .max_samples = 1 << 18});
        const size_t n = h.num_samples(J);
        std::vector<float> f(n);
        std::vector<int32_t> a(n);
        uint64_t state = n;
        for (size_t i = 0; i < n; ++i) {
            state = state * 6364136223846793005u + 1442695040888963407u;
            a[i] = static_cast<int32_t>(state >> 44) - (1 << 19);  // within +-2^20
            f[i] = static_cast<float>(a[i] & 255);
        }
        const std::vector<float> f0 = f;
        const std::vector<int32_t> a0 = a;
        std::span<float> fp[] = {f};
        std::span<int32_t> ap[] = {a};
        forward_transform(h, fp);
        inverse_transform(h, fp);
        forward_transform_int(h, ap);
        inverse_transform_int(h, ap);
        if (a != a0) fail("the integer transform does not reconstruct exactly");
        for (size_t i = 0; i < n; ++i) {
            if (!(std::abs(f[i] - f0[i]) <= 1e-3f))
                fail("the float transform does not reconstruct");
        }
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    Mesh mesh;
    try {
        mesh = parse_mesh(text, "fuzz.json");
    } catch (const Error& e) {
        check_message(e);
        return 0;
    }
    const ValidationReport report = validate(mesh);
    if (!report.ok()) {
        try {
            require_valid(mesh, "fuzz.json");
            fail("require_valid accepted a mesh validate() rejects");
        } catch (const Error& e) {
            check_message(e);
        }
        try {
            build_hierarchy(mesh, {.levels = 1});
            fail("build_hierarchy accepted a mesh validate() rejects");
        } catch (const Error& e) {
            check_message(e);
        }
        level_counts(mesh, 2);  // counts any parsed mesh
        return 0;
    }
    try {
        round_trips(mesh);
    } catch (const Error& e) {  // the sample limit
        check_message(e);
    }
    return 0;
}
