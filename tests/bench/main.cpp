// The benchmarks run with the tesswave command's heap policy (core/math/heap.h): they measure the
// kernels as the command runs them, where a freed frame's pages are reused rather than faulted in
// again.
#include <benchmark/benchmark.h>

#include "core/math/heap.h"

int main(int argc, char** argv) {
    tesswave::keep_freed_blocks();
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
