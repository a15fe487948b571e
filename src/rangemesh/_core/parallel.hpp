// A kernel's threads, one idiom (as manifold keeps one parallel.h): `split_run` for a fixed split
// of independent work, `Worker` for a second thread that a kernel hands work phase after phase.
//
// Every thread is started by `polled_thread` (interrupt.hpp), so Ctrl-C reaches its kernels as it
// does the calling thread's; every thread is joined before these return or unwind, and an
// exception thrown on any of them is rethrown on the calling thread. Which thread runs which
// part never changes the result: each part writes its own outputs.
#pragma once

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "interrupt.hpp"
#include "views.hpp"

namespace rangemesh {

class Worker;

// The Worker that `split_run` on this thread hands the second of two parts to while it is idle,
// instead of starting a thread for it (`LendWorker`); null when there is none.
inline Worker*& lent_worker() noexcept {
    static thread_local Worker* worker = nullptr;
    return worker;
}

// Runs `fa` on the lent worker and `fb` here and returns true when the worker is idle; else
// runs neither and returns false.
template <class A, class B>
bool on_lent_worker(A&& fa, B&& fb);

// Run `part(k, begin, end)` for k in [0, parts) over the fixed split [k n / parts, (k + 1) n /
// parts) of [0, n): part 0 on the calling thread, the others on threads of their own (part 1 of
// two on the lent worker when it is idle). Rethrows the first failed part's exception (by k)
// once every thread is joined.
template <class F>
void split_run(index_t parts, index_t n, F&& part) {
    parts = std::max<index_t>(parts, 1);
    const auto bound = [&](index_t k) { return k * (n / parts) + k * (n % parts) / parts; };
    if (parts == 1) {
        part(index_t{0}, index_t{0}, n);
        return;
    }
    std::vector<std::exception_ptr> failed(static_cast<std::size_t>(parts));
    const auto run = [&](index_t k) {
        try {
            part(k, bound(k), bound(k + 1));
        } catch (...) {
            failed[static_cast<std::size_t>(k)] = std::current_exception();
        }
    };
    const auto rethrow = [&] {
        for (const std::exception_ptr& e : failed)
            if (e) std::rethrow_exception(e);
    };
    // two parts and the call's second thread idle: a wake-up instead of a thread's start
    if (parts == 2 && on_lent_worker([&] { run(1); }, [&] { run(0); })) return rethrow();
    std::vector<std::thread> threads;
    struct JoinAll {
        std::vector<std::thread>& threads;
        ~JoinAll() {
            for (std::thread& t : threads)
                if (t.joinable()) t.join();
        }
    } join_all{threads};  // joined even when starting a thread throws
    threads.reserve(static_cast<std::size_t>(parts - 1));  // push_back then never drops a running thread
    for (index_t k = 1; k < parts; ++k) threads.push_back(polled_thread(run, k));
    run(0);
    for (std::thread& t : threads) t.join();
    rethrow();
}

// A second thread, started once a call: runs the half of each phase that `both` hands it while
// the calling thread runs the other.
class Worker {
  public:
    Worker() : thread_(polled_thread([this] { loop(); })) {}

    ~Worker() {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            stop_ = true;
        }
        wake_.notify_all();
        thread_.join();
    }

    Worker(const Worker&) = delete;
    Worker& operator=(const Worker&) = delete;

    // Run `fa` on the worker and `fb` here; once both are done, rethrow what either threw.
    template <class A, class B>
    void both(A&& fa, B&& fb) {
        const Busy busy(busy_);
        {
            std::lock_guard<std::mutex> lock(mutex_);
            task_ = std::forward<A>(fa);
            done_ = false;
            failed_ = nullptr;
        }
        wake_.notify_all();
        const std::exception_ptr mine = caught(fb);
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return done_; });
        if (mine) std::rethrow_exception(mine);
        if (failed_) std::rethrow_exception(failed_);
    }

    // Whether no `both` is under way (asked on the thread that calls `both`).
    bool idle() const { return !busy_; }

  private:
    // `busy` set while alive.
    struct Busy {
        bool& busy;
        explicit Busy(bool& b) : busy(b) { busy = true; }
        ~Busy() { busy = false; }
    };

    // What `f()` threw, or null.
    template <class F>
    static std::exception_ptr caught(F& f) {
        try {
            f();
        } catch (...) {
            return std::current_exception();
        }
        return nullptr;
    }

    void loop() {
        std::unique_lock<std::mutex> lock(mutex_);
        for (;;) {
            wake_.wait(lock, [this] { return stop_ || task_; });
            if (!task_) return;  // stopped, nothing left to run
            std::function<void()> task = std::move(task_);
            task_ = nullptr;
            lock.unlock();
            const std::exception_ptr failed = caught(task);
            lock.lock();
            failed_ = failed;
            done_ = true;
            wake_.notify_all();
        }
    }

    std::mutex mutex_;
    std::condition_variable wake_;
    std::function<void()> task_;
    bool done_ = true, stop_ = false;
    bool busy_ = false;  // a `both` is under way: read and written by the calling thread only
    std::exception_ptr failed_;
    std::thread thread_;  // last: it starts once the members it uses exist
};

template <class A, class B>
bool on_lent_worker(A&& fa, B&& fb) {
    Worker* const worker = lent_worker();
    if (worker == nullptr || !worker->idle()) return false;  // (a part of its `both` splits)
    worker->both(std::forward<A>(fa), std::forward<B>(fb));
    return true;
}

// While alive, `split_run` on this thread may hand a part to `worker` (its calling thread's).
class LendWorker {
  public:
    explicit LendWorker(Worker* worker) : before_(lent_worker()) { lent_worker() = worker; }
    ~LendWorker() { lent_worker() = before_; }
    LendWorker(const LendWorker&) = delete;
    LendWorker& operator=(const LendWorker&) = delete;

  private:
    Worker* before_;
};

// Run `fa` and `fb`: on the worker and here when there is one, else one after the other.
template <class A, class B>
void run_both(Worker* worker, A&& fa, B&& fb) {
    if (worker) {
        worker->both(std::forward<A>(fa), std::forward<B>(fb));
        return;
    }
    fa();
    fb();
}

}  // namespace rangemesh
