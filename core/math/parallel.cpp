#include "core/math/parallel.h"

#include <pthread.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
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

// Worker threads that live as long as the process and run the pieces of one parallel_for at a
// time: a call costs a wake-up, not a thread's creation. The caller takes pieces too, so that a
// call with p pieces keeps p threads busy. A second caller that finds the pool busy (another
// thread of the program) runs its pieces itself: kernels give the same result on any split.
class Pool {
  public:
    // Runs piece(p) for p in [0, pieces) on the caller and up to threads - 1 workers, each taking
    // the next piece when it is free; true if the pool took the job, false if it was busy.
    bool run(int64_t pieces, int threads, const std::function<void(int64_t)>& piece) {
        std::unique_lock job(job_mutex_, std::try_to_lock);
        if (!job.owns_lock()) return false;
        grow(threads - 1);
        {
            const std::lock_guard lock(mutex_);
            piece_ = &piece;
            pieces_ = pieces;
            next_.store(0);
            helpers_.store(threads - 1);
            finished_ = 0;
            ++generation_;
        }
        wake_.notify_all();
        const int64_t mine = take();
        std::unique_lock lock(mutex_);
        finished_ += mine;
        done_.wait(lock, [&] { return finished_ == pieces_; });
        piece_ = nullptr;
        return true;
    }

  private:
    // Runs pieces until none is left; returns how many it ran.
    int64_t take() {
        int64_t ran = 0;
        for (int64_t p = next_.fetch_add(1); p < pieces_; p = next_.fetch_add(1)) {
            (*piece_.load())(p);
            ++ran;
        }
        return ran;
    }

    void grow(int workers) {
        while (static_cast<int>(workers_) < workers) {
            std::thread([this] { work(); }).detach();  // the pool outlives every caller
            ++workers_;
        }
    }

    void work() {
        serial_depth = 1;  // a piece's own parallel_for calls run on the worker
        uint64_t seen = 0;
        for (;;) {
            {
                std::unique_lock lock(mutex_);
                wake_.wait(lock, [&] { return generation_ != seen && piece_ != nullptr; });
                seen = generation_;
            }
            if (helpers_.fetch_sub(1) <= 0) continue;  // the job has the threads it may use
            const int64_t ran = take();
            if (ran == 0) continue;
            const std::lock_guard lock(mutex_);
            finished_ += ran;
            if (finished_ == pieces_) done_.notify_all();
        }
    }

    std::mutex job_mutex_;  // one job at a time
    std::mutex mutex_;
    std::condition_variable wake_, done_;
    // Atomic: a worker that woke for a job that has ended may read them as the next job starts.
    std::atomic<const std::function<void(int64_t)>*> piece_{nullptr};
    std::atomic<int64_t> pieces_{0};
    std::atomic<int64_t> next_{0};
    std::atomic<int> helpers_{0};  // workers that may still join the job
    int64_t finished_ = 0;
    uint64_t generation_ = 0;
    size_t workers_ = 0;  // guarded by job_mutex_
};

// Set in a child forked (without exec) after the pool started: the child has none of the
// workers, and the pool's locks may have been held by one of them at the fork, so the child runs
// every piece itself and touches nothing of the pool (no locks, no threads, no allocation).
std::atomic<bool>& forked() {
    static std::atomic<bool> flag{false};
    return flag;
}

Pool& pool() {
    static Pool* p = [] {
        pthread_atfork(nullptr, nullptr, [] { forked().store(true); });
        return new Pool;  // never destroyed: its detached workers wait on it until exit
    }();
    return *p;
}

}  // namespace

SerialScope::SerialScope() { ++serial_depth; }
SerialScope::~SerialScope() { --serial_depth; }

int thread_count() {
    const int t = configured().load();
    return t > 0 ? t : hardware_threads();
}

void set_thread_count(int threads) { configured().store(std::max(0, threads)); }

namespace {

// body(p) for each p in [0, pieces) on up to `threads` threads (the pool's, or the caller's
// alone), each piece in a SerialScope; the first exception a piece throws is rethrown once every
// piece has run.
void run_pieces(int64_t pieces, int threads, const std::function<void(int64_t)>& body) {
    std::exception_ptr failure;
    std::mutex mutex;
    const std::function<void(int64_t)> piece = [&](int64_t p) {
        const SerialScope no_nesting;
        try {
            body(p);
        } catch (...) {
            const std::lock_guard<std::mutex> lock(mutex);
            if (!failure) failure = std::current_exception();
        }
    };
    if (threads <= 1 || forked().load() || !pool().run(pieces, threads, piece)) {
        for (int64_t p = 0; p < pieces; ++p) piece(p);
    }
    if (failure) std::rethrow_exception(failure);
}

}  // namespace

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
    run_pieces(pieces, static_cast<int>(pieces),
               [&](int64_t p) { f(n * p / pieces, n * (p + 1) / pieces); });
}

void parallel_tasks(int64_t n, const std::function<void(int64_t)>& task) {
    if (n <= 0) return;
    run_pieces(n, serial_depth > 0 ? 1 : static_cast<int>(std::min<int64_t>(n, thread_count())),
               task);
}

}  // namespace tesswave
