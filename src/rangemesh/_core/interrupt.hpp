// Ctrl-C inside a kernel: a flag that the bindings raise on SIGINT and the kernels poll.
//
// A kernel calls `poll_interrupt()` in its outer loops (once an insertion, a row, a tile); when
// the flag is up it throws `Interrupted`, which unwinds through RAII-owned state only, so
// nothing is left half-written. The bindings turn it into the Python handler's own exception
// (KeyboardInterrupt by default). Flat loops over millions of elements poll every POLL_STRIDE
// (`poll_every`), and arrays of millions are zeroed, grown and copied in strides with a poll
// between (`fill_polled`, `grow_polled`, `copy_polled`): one stride takes a millisecond or less.
// Gigabytes of state are given back on a thread of their own (`FreeLater`), so that neither a
// kernel's end nor its unwinding keeps Ctrl-C waiting for the pages to be returned.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <thread>
#include <tuple>
#include <type_traits>
#include <vector>

#include "views.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace rangemesh {

struct Interrupted : std::exception {
    const char* what() const noexcept override { return "interrupted"; }
};

inline std::atomic<bool>& interrupt_flag() {
    static std::atomic<bool> flag{false};
    return flag;
}

// Whether this thread's kernels stop when the flag is up: on the main thread while a watch is
// alive, and on the threads its kernels start (`polled_thread`). Python raises KeyboardInterrupt
// in the main thread only, so a call on any other thread must finish.
inline bool& stops_on_interrupt() noexcept {
    static thread_local bool stops = false;
    return stops;
}

// Throws `Interrupted` once a SIGINT arrived during the current call of the main thread. A
// relaxed load: costs about as much as a branch (the thread's own setting is read only once the
// flag is up).
inline void poll_interrupt() {
    if (interrupt_flag().load(std::memory_order_relaxed) && stops_on_interrupt()) throw Interrupted();
}

// `std::thread(f, args...)` whose kernels stop for Ctrl-C when the calling thread's do: every
// thread a kernel starts is made with it.
template <class F, class... A>
std::thread polled_thread(F&& f, A&&... args) {
    return std::thread(
        [stops = stops_on_interrupt()](auto run, auto... a) {
            stops_on_interrupt() = stops;
            run(std::move(a)...);
        },
        std::forward<F>(f), std::forward<A>(args)...);
}

// Elements between two polls of a flat loop or an array's fill: at a few ns each, well under a
// millisecond (an 8000 x 8000 image's loops run hundreds of millions).
constexpr index_t POLL_STRIDE = index_t{1} << 16;

// `poll_interrupt()` once every POLL_STRIDE values of a loop counter `i`.
inline void poll_every(index_t i) {
    if ((i & (POLL_STRIDE - 1)) == 0) poll_interrupt();
}

// `v.reserve(n)`, its elements copied to the new room in strides with a poll between; on
// Ctrl-C `v` is as it was.
template <class T>
void reserve_polled(std::vector<T>& v, std::size_t n) {
    constexpr auto stride = static_cast<std::size_t>(POLL_STRIDE);
    if (n <= v.capacity()) return;
    std::vector<T> room;
    room.reserve(n);  // untouched pages: the copy (and later writes) touch them
    for (std::size_t i = 0; i < v.size(); i += stride) {
        poll_interrupt();
        room.insert(room.end(), v.begin() + i, v.begin() + std::min(i + stride, v.size()));
    }
    v.swap(room);
}

// `v.resize(n, value)` (the capacity aside), polling between strides: the old elements moved
// to room for `n` when `v` lacks it, then the new ones written.
template <class T>
void grow_polled(std::vector<T>& v, std::size_t n, const T& value = T()) {
    constexpr auto stride = static_cast<std::size_t>(POLL_STRIDE);
    if (n <= v.size()) return;
    reserve_polled(v, n);
    while (v.size() < n) {
        poll_interrupt();
        v.resize(std::min(n, v.size() + stride), value);
    }
}

// `v.assign(n, value)`, polling between strides.
template <class T>
void fill_polled(std::vector<T>& v, std::size_t n, const T& value = T()) {
    v.clear();
    grow_polled(v, n, value);
}

// A copy of `s`, made in strides with a poll between.
template <class T>
std::vector<std::remove_const_t<T>> copy_polled(Span<T> s) {
    std::vector<std::remove_const_t<T>> out;
    out.reserve(static_cast<std::size_t>(s.size));
    for (index_t i = 0; i < s.size; i += POLL_STRIDE) {
        poll_interrupt();
        out.insert(out.end(), s.begin() + i, s.begin() + std::min(i + POLL_STRIDE, s.size));
    }
    return out;
}

// Below this many bytes arrays are freed where they are: a thread would cost more.
constexpr std::size_t LATE_FREE_BYTES = std::size_t{64} << 20;

// Gives the whole pages inside [p, p + bytes) back to the system a slice at a time (Linux). One
// munmap of a gigabyte holds the process's memory map for about 0.1 s, and every other thread's
// mmap waits that long; a slice holds it a millisecond or two.
inline void give_back_pages(const void* p, std::size_t bytes) noexcept {
#if defined(__linux__) && defined(MADV_DONTNEED)
    const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
    if (page == 0 || bytes == 0) return;
    constexpr std::uintptr_t slice = std::uintptr_t{16} << 20;
    const auto begin = reinterpret_cast<std::uintptr_t>(p);
    const std::uintptr_t end = (begin + bytes) / page * page;
    for (std::uintptr_t at = (begin + page - 1) / page * page; at < end; at += slice)
        madvise(reinterpret_cast<void*>(at), std::min(slice, end - at), MADV_DONTNEED);
#else
    (void)p;
    (void)bytes;
#endif
}

// The vectors' memory freed on a detached thread when it is LATE_FREE_BYTES or more (returning
// a gigabyte of pages to the system takes about 0.1 s, which Ctrl-C would wait for); the
// vectors are left empty. Never throws: without a thread they are freed here.
template <class... T>
void free_later(std::vector<T>&... v) noexcept {
    const std::size_t bytes = (std::size_t{0} + ... + (v.capacity() * sizeof(T)));
    if (bytes < LATE_FREE_BYTES) return;  // their owners free them as usual
    try {
        std::thread([held = std::make_tuple(std::move(v)...)]() mutable {
            std::apply([](auto&... x) { (give_back_pages(x.data(), x.capacity() * sizeof(*x.data())), ...); }, held);
        }).detach();
    } catch (...) {  // no thread to be had: the moved vectors were freed while unwinding
    }
}

// `FreeLater late(on_throw, ...)`: only when an exception ends the scope (a kernel's outputs,
// which its caller keeps when it returns).
struct OnThrow {};
inline constexpr OnThrow on_throw{};

// Hands the vectors it names to `free_later` when it goes out of scope, however the scope ends
// (scratch arrays), or with `on_throw` first only when an exception ends it. Declared after the
// vectors, it runs before their own destructors, which then free nothing.
template <class... T>
class FreeLater {
  public:
    explicit FreeLater(std::vector<T>&... v) : v_(v...) {}
    explicit FreeLater(OnThrow, std::vector<T>&... v) : v_(v...), uncaught_(std::uncaught_exceptions()) {}
    ~FreeLater() {
        if (uncaught_ < 0 || std::uncaught_exceptions() > uncaught_)
            std::apply([](auto&... v) { free_later(v...); }, v_);
    }
    FreeLater(const FreeLater&) = delete;
    FreeLater& operator=(const FreeLater&) = delete;

  private:
    std::tuple<std::vector<T>&...> v_;
    int uncaught_ = -1;  // -1: always; else the exceptions in flight when it was made
};

}  // namespace rangemesh
