// Work sharing across cores: one static split of an index range over a few threads, run by a pool
// of workers that lives as long as the process (a call costs a wake-up, not a thread's start).
// Every kernel that uses it writes disjoint outputs per index, so results are identical to the
// bit whatever the thread count or split (tests pin this).
#pragma once

#include <cstdint>
#include <functional>

namespace tesswave {

// The threads parallel_for may use: all cores by default (`tesswave --threads N`); 1 runs
// everything on the calling thread.
int thread_count();
void set_thread_count(int threads);  // 0: all cores

// While one lives, parallel_for on this thread runs serially: for callers that already keep every
// core busy (one frame per core), and inside parallel_for's own pieces (no nesting).
class SerialScope {
  public:
    SerialScope();
    ~SerialScope();
    SerialScope(const SerialScope&) = delete;
    SerialScope& operator=(const SerialScope&) = delete;
};

// Calls f(begin, end) on contiguous pieces covering [0, n), on up to thread_count() threads
// (the calling thread takes the first piece), at least `min_chunk` indices a piece, and returns
// when all are done. The first exception a piece throws is rethrown here.
void parallel_for(int64_t n, const std::function<void(int64_t, int64_t)>& f, int64_t min_chunk = 1);

// Calls task(k) for each k in [0, n) on up to thread_count() threads, each thread taking the next
// task in order when it is free: for tasks of unequal size (put the longest first), where
// parallel_for's even split would leave a core idle. Each task runs serially inside (no nesting).
// The first exception a task throws is rethrown here, after every task has run.
void parallel_tasks(int64_t n, const std::function<void(int64_t)>& task);

}  // namespace tesswave
