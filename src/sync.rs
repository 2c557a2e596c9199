//! The synchronisation facade: the only module of the crate that names atomics, `UnsafeCell`,
//! threads and locks.
//!
//! Every concurrent data structure in [`crate::cache`] takes its primitives from here, so the code
//! that ships is the code that the model checkers run:
//!
//! * default build: `std` types;
//! * feature `loom`: [`loom`](https://docs.rs/loom) types, explored exhaustively by `loom::model`;
//! * feature `shuttle`: [`shuttle`](https://docs.rs/shuttle) types, explored by random and PCT schedulers.
//!
//! The two checker features are mutually exclusive. `UnsafeCell` always has loom's closure-based
//! shape (`with` / `with_mut`), so loom can track every access to a cell's contents; under `std` and
//! `shuttle` the closures compile to a plain pointer access.

#[cfg(all(feature = "loom", feature = "shuttle"))]
compile_error!(
    "features `loom` and `shuttle` are mutually exclusive: enable one model checker at a time \
     (`cargo test --features loom` or `cargo test --features shuttle`)"
);

#[cfg(feature = "loom")]
mod imp {
    pub use loom::cell::UnsafeCell;
    pub use loom::sync::atomic::{fence, AtomicBool, AtomicPtr, AtomicU8, AtomicUsize, Ordering};
    pub use loom::sync::{Arc, Mutex, MutexGuard, RwLock, RwLockReadGuard, RwLockWriteGuard};
    pub use loom::thread;
}

#[cfg(all(feature = "shuttle", not(feature = "loom")))]
mod imp {
    pub use super::cell::UnsafeCell;
    pub use shuttle::sync::atomic::{
        fence, AtomicBool, AtomicPtr, AtomicU8, AtomicUsize, Ordering,
    };
    pub use shuttle::sync::{Arc, Mutex, MutexGuard, RwLock, RwLockReadGuard, RwLockWriteGuard};
    pub use shuttle::thread;
}

#[cfg(not(any(feature = "loom", feature = "shuttle")))]
mod imp {
    pub use super::cell::UnsafeCell;
    pub use std::sync::atomic::{fence, AtomicBool, AtomicPtr, AtomicU8, AtomicUsize, Ordering};
    pub use std::sync::{Arc, Mutex, MutexGuard, RwLock, RwLockReadGuard, RwLockWriteGuard};
    pub use std::thread;
}

pub use imp::*;

/// A leak tracker for an object the caches own through a raw pointer (a WF node, a slot of a WF
/// list segment): embed one in the object, made with the object.
///
/// Under `loom` it is a `loom::alloc::Track`: loom registers it when it is made and marks it when
/// it is dropped, and at the end of every execution fails the model with loom's report
/// (`Allocation leaked.`, plus `Allocated: <file>:<line>` when `LOOM_LOCATION` is set) if one was
/// never dropped. So an object that some schedule allocates and never frees (a private subtree a
/// compare-and-swap loser forgets, a segment the loser of an install keeps) fails every loom model
/// that reaches that schedule. Elsewhere it is zero-sized with alignment 1 (asserted below) and
/// adds nothing to the object. Shuttle has no leak tracking.
#[derive(Debug)]
pub struct Tracked {
    #[cfg(feature = "loom")]
    _track: loom::alloc::Track<()>,
}

impl Tracked {
    /// A tracker for an object being made (under loom, only inside a model). The location loom
    /// reports is the caller's (`#[track_caller]` under loom; so are the constructors that make
    /// one, so the report names where the node or segment was allocated).
    #[cfg_attr(feature = "loom", track_caller)]
    #[inline(always)]
    #[allow(clippy::new_without_default)] // a tracker is made on purpose, with its object
    pub fn new() -> Self {
        Self {
            #[cfg(feature = "loom")]
            _track: loom::alloc::Track::new(()),
        }
    }
}

// Outside loom the tracker must cost nothing: no byte, no alignment, in any object that holds one.
#[cfg(not(feature = "loom"))]
const _: () = assert!(std::mem::size_of::<Tracked>() == 0 && std::mem::align_of::<Tracked>() == 1);

/// Primitives the model checkers must *not* see: std's, whatever the feature. Only for
/// instrumentation and bookkeeping that watch the checked code without taking part in its
/// protocol: the linearizability recorder's clock, the frame ledger of
/// [`crate::cache::frame`] (locked once when a handle is made and once when it is dropped, never
/// on a lookup or an insert, and holding nothing that another worker reads during the frame), and
/// the tests' own bookkeeping (the leak tests' allocation counters and their serialising lock).
/// Under loom or shuttle these are invisible: no schedule point, and no happens-before edge in
/// the checker's view. A checker that cannot see an edge explores more executions, not fewer, so
/// they cannot hide a bug. Never use them for data that workers exchange.
pub mod unchecked {
    pub use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
    pub use std::sync::{Mutex, MutexGuard};
}
pub use std::sync::{LockResult, PoisonError, TryLockError};

/// A `std::cell::UnsafeCell` with loom's API shape, used where loom itself is not.
#[cfg(not(feature = "loom"))]
mod cell {
    /// Interior mutability with access through closures, as `loom::cell::UnsafeCell` offers it.
    ///
    /// Under `std` and `shuttle` this is a zero-cost wrapper: shuttle checks schedules, not
    /// memory accesses, so it has no cell of its own.
    #[derive(Debug, Default)]
    pub struct UnsafeCell<T>(std::cell::UnsafeCell<T>);

    impl<T> UnsafeCell<T> {
        /// Wraps `value`.
        pub fn new(value: T) -> Self {
            Self(std::cell::UnsafeCell::new(value))
        }

        /// Calls `f` with a shared raw pointer to the contents.
        #[inline(always)]
        pub fn with<R>(&self, f: impl FnOnce(*const T) -> R) -> R {
            f(self.0.get())
        }

        /// Calls `f` with a unique raw pointer to the contents.
        #[inline(always)]
        pub fn with_mut<R>(&self, f: impl FnOnce(*mut T) -> R) -> R {
            f(self.0.get())
        }
    }
}

/// Recovers the guard of a poisoned lock.
///
/// A worker that panics while it holds a cache lock poisons it. The caches keep their invariants
/// at every point where a panic can unwind (a record is pushed whole or not at all), so the data
/// behind a poisoned lock is sound and the other workers go on with it.
pub fn unpoison<G>(result: LockResult<G>) -> G {
    result.unwrap_or_else(PoisonError::into_inner)
}

/// Recovers a guard from a `try_*` call: `Some` when the lock was free (poisoned or not).
pub fn try_unpoison<G>(result: Result<G, TryLockError<G>>) -> Option<G> {
    match result {
        Ok(guard) => Some(guard),
        Err(TryLockError::Poisoned(poisoned)) => Some(poisoned.into_inner()),
        Err(TryLockError::WouldBlock) => None,
    }
}
