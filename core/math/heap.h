// The process's heap policy, set by the tesswave command and by the benchmarks, so that they
// measure what the command does.
#pragma once

#include <malloc.h>

namespace tesswave {

// Frames, planes and images (megabytes each) are allocated and freed again for every frame: keep
// them in the heap rather than mapping them afresh and faulting their pages in each time. A
// 30-frame face morph spent 1.3 s of its 5 s of CPU in the kernel that way, 0.35 s with this.
inline void keep_freed_blocks() {
    mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's largest
    mallopt(M_TRIM_THRESHOLD, 1 << 30);
}

}  // namespace tesswave
