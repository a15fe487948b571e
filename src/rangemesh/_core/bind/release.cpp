#include "release.hpp"

#include <Python.h>

#include <csignal>

namespace rangemesh::bind {

namespace {

int depth = 0;  // nested watches (main thread only) install the handler once

#ifdef _WIN32
using Handler = void (*)(int);
Handler previous = SIG_DFL;

extern "C" void on_sigint(int signum) {
    interrupt_flag().store(true, std::memory_order_relaxed);
    std::signal(SIGINT, on_sigint);  // Windows resets the handler on delivery
    if (previous != SIG_DFL && previous != SIG_IGN && previous != SIG_ERR) previous(signum);
}

bool install() {
    previous = std::signal(SIGINT, on_sigint);
    if (previous == SIG_ERR) return false;
    if (previous == SIG_IGN) {  // an ignored SIGINT stays ignored
        std::signal(SIGINT, previous);
        return false;
    }
    return true;
}

void restore() { std::signal(SIGINT, previous); }
#else
struct sigaction previous{};

extern "C" void on_sigint(int signum, siginfo_t* info, void* context) {
    interrupt_flag().store(true, std::memory_order_relaxed);
    // chain to Python's own C-level handler, which marks the signal for its Python handler
    if (previous.sa_flags & SA_SIGINFO) {
        if (previous.sa_sigaction != nullptr) previous.sa_sigaction(signum, info, context);
    } else if (previous.sa_handler != SIG_DFL && previous.sa_handler != SIG_IGN) {
        previous.sa_handler(signum);
    }
}

bool install() {
    struct sigaction action{};
    action.sa_sigaction = on_sigint;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_SIGINFO;
    if (sigaction(SIGINT, &action, &previous) != 0) return false;
    if (!(previous.sa_flags & SA_SIGINFO) && previous.sa_handler == SIG_IGN) {
        sigaction(SIGINT, &previous, nullptr);  // an ignored SIGINT stays ignored
        return false;
    }
    return true;
}

void restore() { sigaction(SIGINT, &previous, nullptr); }
#endif

}  // namespace

SigintWatch::SigintWatch() {
    if (!_PyOS_IsMainThread()) return;
    counted_ = true;
    if (depth++ > 0) return;
    interrupt_flag().store(false, std::memory_order_relaxed);
    stops_on_interrupt() = true;  // the flag is process-wide: only this thread's kernels heed it
    active_ = install();
}

SigintWatch::~SigintWatch() {
    if (active_) restore();
    // a signal the kernel did not poll in time has reached Python's handler already: the
    // flag must not stop the next kernel
    if (counted_ && --depth == 0) {
        interrupt_flag().store(false, std::memory_order_relaxed);
        stops_on_interrupt() = false;
    }
}

void raise_interrupted() {
    interrupt_flag().store(false, std::memory_order_relaxed);
    if (PyErr_CheckSignals() != 0) throw nanobind::python_error();
    PyErr_SetNone(PyExc_KeyboardInterrupt);
    throw nanobind::python_error();
}

}  // namespace rangemesh::bind
