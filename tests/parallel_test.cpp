#include "core/math/parallel.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <mutex>
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

// parallel_tasks runs every task once, on no more threads than allowed even when the pool has
// more workers, and hands tasks out as threads come free: the first task waits until every other
// one has run, which an even split of the tasks over two threads would never let happen.
TEST(Parallel, tasks_go_to_whichever_thread_is_free) {
    set_thread_count(5);
    parallel_for(5, [](int64_t, int64_t) {});  // five threads in the pool
    for (int threads : {1, 2, 3}) {
        set_thread_count(threads);
        std::vector<std::atomic<int>> seen(40);
        std::atomic<int> running{0}, peak{0};
        parallel_tasks(40, [&](int64_t k) {
            const int now = ++running;
            int seen_peak = peak.load();
            while (now > seen_peak && !peak.compare_exchange_weak(seen_peak, now)) {
            }
            std::this_thread::sleep_for(std::chrono::microseconds(200));
            ++seen[static_cast<size_t>(k)];
            --running;
        });
        for (size_t k = 0; k < seen.size(); ++k)
            ASSERT_EQ(seen[k].load(), 1) << threads << " " << k;
        EXPECT_LE(peak.load(), threads);
    }
    set_thread_count(2);
    std::mutex mutex;
    std::condition_variable all_others;
    int others = 0;
    bool waited = false;
    parallel_tasks(8, [&](int64_t k) {
        std::unique_lock lock(mutex);
        if (k == 0) {
            waited =
                all_others.wait_for(lock, std::chrono::seconds(20), [&] { return others == 7; });
        } else if (++others == 7) {
            all_others.notify_all();
        }
    });
    EXPECT_TRUE(waited);
    for (int threads : {1, 2}) {  // the tasks after a failed one still run, on any count
        set_thread_count(threads);
        std::atomic<int> ran{0};
        EXPECT_THROW(parallel_tasks(6,
                                    [&](int64_t k) {
                                        ++ran;
                                        if (k == 1) throw std::runtime_error("task failed");
                                    }),
                     std::runtime_error);
        EXPECT_EQ(ran.load(), 6) << threads << " threads";
    }
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
