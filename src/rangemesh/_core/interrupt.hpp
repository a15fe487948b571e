// Ctrl-C inside a kernel: a flag that the bindings raise on SIGINT and the kernels poll.
//
// A kernel calls `poll_interrupt()` in its outer loops (once an insertion, a row, a tile); when
// the flag is up it throws `Interrupted`, which unwinds through RAII-owned state only, so
// nothing is left half-written. The bindings turn it into the Python handler's own exception
// (KeyboardInterrupt by default).
#pragma once

#include <atomic>
#include <exception>

namespace rangemesh {

struct Interrupted : std::exception {
    const char* what() const noexcept override { return "interrupted"; }
};

inline std::atomic<bool>& interrupt_flag() {
    static std::atomic<bool> flag{false};
    return flag;
}

// Throws `Interrupted` once a SIGINT arrived during the current call. A relaxed load: costs
// about as much as a branch.
inline void poll_interrupt() {
    if (interrupt_flag().load(std::memory_order_relaxed)) throw Interrupted();
}

}  // namespace rangemesh
