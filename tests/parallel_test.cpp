#include "core/math/parallel.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace tesswave {
namespace {

// Every index is visited exactly once, on any thread count and size, call after call (the pool's
// workers are reused across calls).
TEST(Parallel, every_index_runs_once_on_any_thread_count) {
    for (int threads : {1, 2, 3, 5}) {
        set_thread_count(threads);
        for (int64_t n : {1, 2, 3, 7, 64, 1000}) {
            for (int call = 0; call < 20; ++call) {
                std::vector<std::atomic<int>> seen(static_cast<size_t>(n));
                parallel_for(n, [&](int64_t begin, int64_t end) {
                    for (int64_t i = begin; i < end; ++i) ++seen[static_cast<size_t>(i)];
                });
                for (int64_t i = 0; i < n; ++i)
                    ASSERT_EQ(seen[static_cast<size_t>(i)].load(), 1)
                        << threads << " threads, n " << n << ", index " << i;
            }
        }
    }
    set_thread_count(0);
}

// A piece's exception reaches the caller (the first one), and the pool still works afterwards;
// a parallel_for inside a piece runs serially there and completes.
TEST(Parallel, exceptions_reach_the_caller_and_nested_calls_complete) {
    set_thread_count(3);
    EXPECT_THROW(parallel_for(9,
                              [](int64_t begin, int64_t) {
                                  if (begin >= 3) throw std::runtime_error("piece failed");
                              }),
                 std::runtime_error);
    std::atomic<int64_t> total{0};
    parallel_for(6, [&](int64_t begin, int64_t end) {
        for (int64_t i = begin; i < end; ++i) {
            parallel_for(10, [&](int64_t b, int64_t e) { total += e - b; });
        }
    });
    EXPECT_EQ(total.load(), 60);
    set_thread_count(0);
}

// Several program threads calling at once: one gets the pool, the others run their pieces
// themselves; every call still covers its range exactly.
TEST(Parallel, concurrent_callers_each_cover_their_range) {
    set_thread_count(3);
    std::vector<std::thread> callers;
    std::atomic<int> wrong{0};
    for (int t = 0; t < 4; ++t) {
        callers.emplace_back([&, t] {
            for (int call = 0; call < 200; ++call) {
                const int64_t n = 50 + t * 7 + call % 13;
                std::atomic<int64_t> sum{0};
                parallel_for(n, [&](int64_t begin, int64_t end) {
                    for (int64_t i = begin; i < end; ++i) sum += i;
                });
                if (sum.load() != n * (n - 1) / 2) ++wrong;
            }
        });
    }
    for (std::thread& c : callers) c.join();
    EXPECT_EQ(wrong.load(), 0);
    set_thread_count(0);
}

// A child forked without exec has none of the parent's workers: its parallel_for runs every piece
// itself and sums right (a hang here is caught by CTest's timeout).
TEST(Parallel, a_forked_child_runs_its_pieces_itself) {
    set_thread_count(2);
    std::atomic<int64_t> warm{0};
    parallel_for(100, [&](int64_t begin, int64_t end) { warm += end - begin; });  // workers up
    ASSERT_EQ(warm.load(), 100);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        std::atomic<int64_t> sum{0};
        parallel_for(100, [&](int64_t begin, int64_t end) {
            for (int64_t i = begin; i < end; ++i) sum += i;
        });
        std::_Exit(sum.load() == 4950 ? 0 : 1);
    }
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
    set_thread_count(0);
}

}  // namespace
}  // namespace tesswave
