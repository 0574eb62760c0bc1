// The thread count of one benchmark row. The benchmark binary runs single-threaded
// (lifting_bench.cpp sets it at start-up); a row that measures more threads sets its count for
// its lifetime and puts the single thread back when it ends.
#pragma once

#include <cstdint>

#include "core/math/parallel.h"

namespace tesswave {

class RowThreads {
  public:
    explicit RowThreads(int64_t threads) { set_thread_count(static_cast<int>(threads)); }
    ~RowThreads() { set_thread_count(1); }
    RowThreads(const RowThreads&) = delete;
    RowThreads& operator=(const RowThreads&) = delete;
};

}  // namespace tesswave
