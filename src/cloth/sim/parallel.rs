//! Two threads on one cloth: [`Join`], what a step calls to run two halves of its work at
//! once, and [`with_helper`], which lends it a thread of Bevy's compute task pool for a
//! step.
//!
//! A step projects its cloth many times (substeps times iterations, 16 sweeps at 8 x 2), and
//! each sweep would be a fork and a join. A task spawned on the pool per fork costs more than
//! the work it saves: measured here on two cores, two halves of 20 us each took 60-70 us with
//! a scope per fork (the pool's thread sleeps between forks and wakes late) and 21 us with a
//! helper that waits spinning. So a step spawns one helper task ([`with_helper`]) that, once a
//! pool thread runs it, waits for halves to take, spinning briefly and then yielding its
//! thread; every [`Join::join`] hands it the second half while the step's own thread runs the
//! first. Until the helper has started (the pool's threads may all be busy), the step's
//! thread runs both halves itself: nothing ever waits for a thread that is not there, and the
//! result is the same either way.

use std::cell::UnsafeCell;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use bevy::math::Vec3A;
use bevy::tasks::TaskPool;

/// Runs two pieces of work that share no data, at the same time where it can.
pub trait Join: Sync {
    /// Whether [`Join::join`] may run its two closures at once (a step then splits its cloth
    /// in two; with one thread it keeps its single sweep, the reference).
    fn is_parallel(&self) -> bool;

    /// Runs `a` and `b` and returns when both are done.
    fn join(&self, a: &mut dyn FnMut(), b: &mut (dyn FnMut() + Send));
}

/// One thread: `a`, then `b`.
#[derive(Clone, Copy, Debug, Default)]
pub struct OneThread;

impl Join for OneThread {
    fn is_parallel(&self) -> bool {
        false
    }

    fn join(&self, a: &mut dyn FnMut(), b: &mut (dyn FnMut() + Send)) {
        a();
        b();
    }
}

/// The helper has not started.
const WAITING: u32 = 0;
/// The helper runs and takes the halves posted to it.
const JOINED: u32 = 1;
/// The step is over: a helper that starts now returns at once.
const FINISHED: u32 = 2;

/// Spins before a waiting thread starts yielding its core.
const SPINS: u32 = 2000;

/// The [`Join`] of [`with_helper`]: the step's thread posts second halves to a helper task.
struct Helper {
    state: AtomicU32,
    /// Halves posted, and halves the helper has finished.
    posted: AtomicU32,
    done: AtomicU32,
    /// The half posted last: written by the step's thread before `posted` is raised, read by
    /// the helper after it sees it raised.
    job: UnsafeCell<Option<*mut (dyn FnMut() + Send + 'static)>>,
    panicked: AtomicBool,
}

// SAFETY: `job` is written by the step's thread only while the helper is not running a job
// (before `posted` is raised, after `done` caught up), and read by the helper only between
// seeing `posted` raised and raising `done` (release/acquire on both counters); the closure
// it points to is `Send`.
unsafe impl Sync for Helper {}

impl Helper {
    fn new() -> Self {
        Self {
            state: AtomicU32::new(WAITING),
            posted: AtomicU32::new(0),
            done: AtomicU32::new(0),
            job: UnsafeCell::new(None),
            panicked: AtomicBool::new(false),
        }
    }

    /// The helper task: joins unless the step is over, then runs each half posted until the
    /// step finishes.
    fn serve(&self) {
        if self
            .state
            .compare_exchange(WAITING, JOINED, Ordering::AcqRel, Ordering::Acquire)
            .is_err()
        {
            return;
        }
        let mut finished = self.done.load(Ordering::Acquire);
        let mut spins = 0;
        loop {
            if self.posted.load(Ordering::Acquire) > finished {
                // SAFETY: the step's thread wrote the job before raising `posted` and does
                // not touch it until `done` is raised below; the closure outlives that wait.
                let job = unsafe { (*self.job.get()).take() };
                if let Some(job) = job {
                    // SAFETY: as above: the step's thread keeps the closure alive and
                    // untouched until `done` is raised.
                    let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| unsafe {
                        (*job)()
                    }));
                    if run.is_err() {
                        self.panicked.store(true, Ordering::Release);
                    }
                }
                finished += 1;
                self.done.store(finished, Ordering::Release);
                spins = 0;
            } else if self.state.load(Ordering::Acquire) == FINISHED {
                return;
            } else {
                pause(&mut spins);
            }
        }
    }

    /// Waits until the helper has finished every half posted to it.
    fn wait(&self) {
        let posted = self.posted.load(Ordering::Relaxed);
        let mut spins = 0;
        while self.done.load(Ordering::Acquire) < posted {
            pause(&mut spins);
        }
    }
}

/// Spins, then yields the thread (so that a waiting thread leaves its core to others).
fn pause(spins: &mut u32) {
    if *spins < SPINS {
        *spins += 1;
        std::hint::spin_loop();
    } else {
        std::thread::yield_now();
    }
}

/// Waits for the helper's half even if the step's half panics, so that the helper never
/// runs a closure whose borrows have ended.
struct WaitOnDrop<'a>(&'a Helper);

impl Drop for WaitOnDrop<'_> {
    fn drop(&mut self) {
        self.0.wait();
    }
}

impl Join for Helper {
    fn is_parallel(&self) -> bool {
        true
    }

    fn join(&self, a: &mut dyn FnMut(), b: &mut (dyn FnMut() + Send)) {
        if self.state.load(Ordering::Acquire) != JOINED {
            a();
            b();
            return;
        }
        let b: *mut (dyn FnMut() + Send + '_) = b;
        // SAFETY: the lifetime is erased only for the time the helper holds the pointer: this
        // function does not return (nor unwind, `WaitOnDrop`) before the helper is done.
        let b: *mut (dyn FnMut() + Send + 'static) = unsafe { std::mem::transmute(b) };
        // SAFETY: the helper is not running a job (every earlier join waited for it).
        unsafe { *self.job.get() = Some(b) };
        self.posted.fetch_add(1, Ordering::Release);
        {
            let _wait = WaitOnDrop(self);
            a();
        }
        if self.panicked.swap(false, Ordering::AcqRel) {
            panic!("a cloth step's second half panicked on the helper thread");
        }
    }
}

/// Runs `f` with a [`Join`] that hands second halves to a helper task on `pool` (see the
/// module documentation), and returns what `f` returns. The helper waits, spinning and then
/// yielding, for as long as `f` runs: call it around one step, not around other work.
pub fn with_helper<R: Send>(pool: &TaskPool, f: impl FnOnce(&dyn Join) -> R + Send) -> R {
    let helper = Helper::new();
    let mut result = None;
    {
        let (helper, result) = (&helper, &mut result);
        pool.scope(move |scope| {
            scope.spawn(async move { helper.serve() });
            // Every join has waited for its half; a helper still to start now returns at once.
            struct Finish<'a>(&'a Helper);
            impl Drop for Finish<'_> {
                fn drop(&mut self) {
                    self.0.state.store(FINISHED, Ordering::Release);
                }
            }
            let _finish = Finish(helper);
            *result = Some(f(helper));
        });
    }
    match result {
        Some(r) => r,
        None => unreachable!("the scope ran its body"),
    }
}

/// A run of particles: their positions, previous positions, velocities and inverse masses,
/// from particle `first` on.
pub(super) struct Particles<'a> {
    pub(super) x: &'a mut [Vec3A],
    pub(super) x_prev: &'a mut [Vec3A],
    pub(super) v: &'a mut [Vec3A],
    pub(super) w: &'a [f32],
    pub(super) first: usize,
}

/// Runs `f` on every particle: on all of them at once, or with `middle` on the two halves
/// split there, at the same time through `join`.
pub(super) fn per_half(
    join: &dyn Join,
    middle: Option<usize>,
    x: &mut [Vec3A],
    x_prev: &mut [Vec3A],
    v: &mut [Vec3A],
    w: &[f32],
    f: impl Fn(Particles) + Sync,
) {
    let n = x.len();
    let middle = middle.filter(|&m| m <= n && x_prev.len() == n && v.len() == n && w.len() == n);
    let Some(m) = middle else {
        f(Particles {
            x,
            x_prev,
            v,
            w,
            first: 0,
        });
        return;
    };
    let (x0, x1) = x.split_at_mut(m);
    let (p0, p1) = x_prev.split_at_mut(m);
    let (v0, v1) = v.split_at_mut(m);
    let (w0, w1) = w.split_at(m);
    let f = &f;
    join.join(
        &mut || {
            f(Particles {
                x: &mut *x0,
                x_prev: &mut *p0,
                v: &mut *v0,
                w: w0,
                first: 0,
            })
        },
        &mut || {
            f(Particles {
                x: &mut *x1,
                x_prev: &mut *p1,
                v: &mut *v1,
                w: w1,
                first: m,
            })
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::tasks::TaskPoolBuilder;

    /// Both halves run, each exactly once per join, whether or not the helper has started,
    /// and what they write is seen after the join.
    #[test]
    fn every_half_runs_once_and_its_writes_are_seen() {
        let pool = TaskPoolBuilder::new().num_threads(1).build();
        let mut left = vec![0u64; 1000];
        let mut right = vec![0u64; 1000];
        let joins = 500;
        let parallel = with_helper(&pool, |join| {
            for k in 0..joins {
                let (l, r) = (&mut left, &mut right);
                join.join(&mut || l.iter_mut().for_each(|v| *v += k), &mut || {
                    r.iter_mut().for_each(|v| *v += 2 * k)
                });
                assert_eq!(right[0], (0..=k).map(|j| 2 * j).sum::<u64>());
            }
            join.is_parallel()
        });
        assert!(parallel);
        let sum: u64 = (0..joins).sum();
        assert!(left.iter().all(|&v| v == sum));
        assert!(right.iter().all(|&v| v == 2 * sum));
    }

    /// A pool whose one thread is busy: the step's thread runs both halves itself and
    /// nothing waits for the helper.
    #[test]
    fn a_busy_pool_costs_no_wait() {
        let pool = TaskPoolBuilder::new().num_threads(1).build();
        let release = AtomicBool::new(false);
        pool.scope(|outer| {
            outer.spawn(async {
                while !release.load(Ordering::Acquire) {
                    std::thread::yield_now();
                }
            });
            let (mut count, mut other) = (0, 0);
            with_helper(&pool, |join| {
                // The busy task ends once a half has run, whoever runs it.
                join.join(&mut || count += 1, &mut || {
                    other += 1;
                    release.store(true, Ordering::Release);
                });
            });
            assert_eq!((count, other), (1, 1));
        });
    }

    /// A panic in the helper's half reaches the step's thread.
    #[test]
    fn a_panicking_half_panics_the_join() {
        let pool = TaskPoolBuilder::new().num_threads(1).build();
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            with_helper(&pool, |join| {
                for _ in 0..100 {
                    join.join(&mut || {}, &mut || panic!("half"));
                }
            })
        }));
        assert!(outcome.is_err());
    }
}
