// Running a kernel with the GIL released and Ctrl-C noted: `run_released(f)`.
#pragma once

#include <nanobind/nanobind.h>

#include <utility>

#include "../interrupt.hpp"
#include "../views.hpp"

namespace rangemesh::bind {

// While alive (main thread only), SIGINT raises the kernels' interrupt flag and then runs the
// handler that was installed before, so Python still learns of the signal. Only the kernels of
// the main thread and of the threads they start heed the flag (`stops_on_interrupt`).
class SigintWatch {
  public:
    SigintWatch();
    ~SigintWatch();
    SigintWatch(const SigintWatch&) = delete;
    SigintWatch& operator=(const SigintWatch&) = delete;

  private:
    bool counted_ = false;  // on the main thread, in the nesting count
    bool active_ = false;   // installed the handler
};

// Raise the Python exception for a kernel stopped by Ctrl-C: whatever Python's SIGINT handler
// raises (KeyboardInterrupt by default), or KeyboardInterrupt if it raises nothing.
[[noreturn]] void raise_interrupted();

// Below this many elements (pixels, faces, points) a kernel takes microseconds: it runs with
// the GIL held and no watch, whose two signal-handler swaps would cost more than the work.
constexpr index_t SMALL_WORK = index_t{1} << 12;

// Call `f()` with the GIL released and Ctrl-C watched; returns what `f` returns. `work` is the
// size of the input that bounds its running time; under SMALL_WORK `f` simply runs.
template <class F>
auto run_released(F&& f, index_t work = SMALL_WORK) {
    if (work < SMALL_WORK) {
        try {
            return std::forward<F>(f)();
        } catch (const Interrupted&) {  // kernels poll a flag only a watch raises: cannot happen
            raise_interrupted();
        }
    }
    // a Ctrl-C that came just before the call is raised now, not after the whole kernel
    if (PyErr_CheckSignals() != 0) throw nanobind::python_error();
    SigintWatch watch;
    try {
        nanobind::gil_scoped_release released;
        return std::forward<F>(f)();
    } catch (const Interrupted&) {
        raise_interrupted();
    }
}

}  // namespace rangemesh::bind
