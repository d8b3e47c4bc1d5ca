// pacing.cpp — the monotonic clock, the absolute-deadline sleep, the realtime priority request and
// the process-wide realtime settings.
#include "haptics/pacing.h"

#include <palpate/haptics.h>

#include <cerrno>
#include <malloc.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
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

RealtimeProcess prepare_realtime_process() noexcept {
  RealtimeProcess r;
  r.malloc_pinned = ::mallopt(M_MMAP_MAX, 0) == 1 && ::mallopt(M_TRIM_THRESHOLD, -1) == 1;
  // Locking all future pages too needs an unlimited memory-lock limit, or a large allocation
  // would fail later; with a finite limit, nothing is locked.
  rlimit lim{};
  if (::getrlimit(RLIMIT_MEMLOCK, &lim) == 0 && lim.rlim_cur == RLIM_INFINITY)
    r.memory_locked = ::mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
  return r;
}

}  // namespace palpate
