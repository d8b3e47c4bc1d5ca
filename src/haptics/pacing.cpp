// pacing.cpp — the monotonic clock, the absolute-deadline sleep and the realtime priority request.
#include "haptics/pacing.h"

#include <cerrno>
#include <pthread.h>
#include <sched.h>
#include <time.h>

namespace palpate {

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

void sleep_until_ns(std::int64_t deadline_ns, std::int64_t spin_ns) noexcept {
  const std::int64_t wake = deadline_ns - (spin_ns > 0 ? spin_ns : 0);
  if (monotonic_ns() < wake) {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(wake / 1000000000);
    ts.tv_nsec = static_cast<long>(wake % 1000000000);
    while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
  }
  while (monotonic_ns() < deadline_ns) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  }
}

bool try_realtime_priority(int priority) noexcept {
  sched_param p{};
  p.sched_priority = priority;
  return ::pthread_setschedparam(::pthread_self(), SCHED_FIFO, &p) == 0;
}

}  // namespace palpate
