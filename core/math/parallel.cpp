#include "core/math/parallel.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace tesswave {
namespace {

int hardware_threads() { return std::max(1u, std::thread::hardware_concurrency()); }

std::atomic<int>& configured() {
    static std::atomic<int> threads{0};
    return threads;
}

thread_local int serial_depth = 0;

}  // namespace

SerialScope::SerialScope() { ++serial_depth; }
SerialScope::~SerialScope() { --serial_depth; }

int thread_count() {
    const int t = configured().load();
    return t > 0 ? t : hardware_threads();
}

void set_thread_count(int threads) { configured().store(std::max(0, threads)); }

void parallel_for(int64_t n, const std::function<void(int64_t, int64_t)>& f, int64_t min_chunk) {
    if (n <= 0) return;
    const int64_t pieces =
        serial_depth > 0
            ? 1
            : std::clamp<int64_t>(n / std::max<int64_t>(1, min_chunk), 1, thread_count());
    if (pieces == 1) {
        f(0, n);
        return;
    }
    std::exception_ptr failure;
    std::mutex mutex;
    auto run = [&](int64_t p) {
        const SerialScope no_nesting;
        try {
            f(n * p / pieces, n * (p + 1) / pieces);
        } catch (...) {
            std::lock_guard<std::mutex> lock(mutex);
            if (!failure) failure = std::current_exception();
        }
    };
    std::vector<std::thread> threads;
    threads.reserve(pieces - 1);
    for (int64_t p = 1; p < pieces; ++p) threads.emplace_back(run, p);
    run(0);
    for (std::thread& t : threads) t.join();
    if (failure) std::rethrow_exception(failure);
}

}  // namespace tesswave
