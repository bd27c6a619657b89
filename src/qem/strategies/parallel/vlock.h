/*
 * Per-element try-locks and a waiting helper for the concurrent queues.
 * Internal.
 *
 * A lock is one atomic byte, 0 free and 1 held, so an array of them costs a
 * byte per element and zero-filled memory (calloc) is an array of free
 * locks. Taking a lock is an acquire and giving it back a release: whatever
 * a holder wrote under the lock is seen by the next holder.
 *
 * Waiting (mr_spin_wait) pauses a growing number of times, then gives the
 * core away (sched_yield) on every later call. The queues' tests run 8
 * threads on 2 cores: a lock holder may be preempted, and a waiter that only
 * spun would burn its whole time slice before the holder runs again.
 */
#ifndef MR_VLOCK_H
#define MR_VLOCK_H

#include <sched.h>
#include <stdatomic.h>
#include <stdbool.h>

typedef atomic_uchar mr_vlock;

/* Waiting state of one waiter: start each wait from MR_SPIN_INIT. */
typedef struct mr_spin {
    unsigned turns;
} mr_spin;
#define MR_SPIN_INIT {0}

/* Rounds of pausing (1, 2, 4, ... 128 pauses, a few microseconds in all)
 * before every further round yields. */
#define MR_SPIN_PAUSE_ROUNDS 8

static inline void mr_cpu_relax(void)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#elif defined(__aarch64__)
    __asm__ __volatile__("yield");
#endif
}

static inline void mr_spin_wait(mr_spin *s)
{
    if (s->turns < MR_SPIN_PAUSE_ROUNDS) {
        for (unsigned i = 0; i < 1u << s->turns; i++)
            mr_cpu_relax();
        s->turns++;
        return;
    }
    sched_yield();
}

/* Take the lock when it is free; never waits. A plain read first keeps a
 * held lock's cache line shared among its waiters. */
static inline bool mr_vlock_try(mr_vlock *l)
{
    return atomic_load_explicit(l, memory_order_relaxed) == 0 &&
           atomic_exchange_explicit(l, 1, memory_order_acquire) == 0;
}

static inline void mr_vlock_lock(mr_vlock *l)
{
    mr_spin s = MR_SPIN_INIT;
    while (!mr_vlock_try(l))
        mr_spin_wait(&s);
}

static inline void mr_vlock_unlock(mr_vlock *l)
{
    atomic_store_explicit(l, 0, memory_order_release);
}

#endif /* MR_VLOCK_H */
