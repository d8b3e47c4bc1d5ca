// pacing.h — monotonic nanosecond clock and the absolute-deadline sleep used by the fixed-period
// threads (haptic loop, multi-rate physics): sleep with clock_nanosleep(TIMER_ABSTIME), spin the end.
#pragma once

#include <cstdint>

namespace palpate {

// CLOCK_MONOTONIC in nanoseconds.
std::int64_t monotonic_ns() noexcept;

// Sleep until `deadline_ns` (CLOCK_MONOTONIC): clock_nanosleep(TIMER_ABSTIME) to `spin_ns` before
// it, then busy-wait the rest, since a sleeping wake-up is late by tens of microseconds under
// load while a spin is exact. An absolute deadline keeps the period from drifting. No allocation.
void sleep_until_ns(std::int64_t deadline_ns, std::int64_t spin_ns) noexcept;

// Ask for SCHED_FIFO at `priority` for the calling thread; false when not permitted.
bool try_realtime_priority(int priority) noexcept;

}  // namespace palpate
