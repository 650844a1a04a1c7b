//! The synchronisation primitives the pool's slots use: core's atomics, `UnsafeCell` and a
//! critical-section mutex on the MCU and the host; loom's under `--cfg loom` (host only), so
//! that the model checker explores every interleaving and every ordering the atomics allow
//! and checks each access to a slot's message against them.

#[cfg(not(loom))]
pub(crate) use core::sync::atomic::{fence, AtomicBool, AtomicU32, Ordering};
#[cfg(loom)]
pub(crate) use loom::sync::atomic::{fence, AtomicBool, AtomicU32, Ordering};

use embassy_sync::waitqueue::WakerRegistration;

/// A slot's message cell. Under loom every access is recorded where the pointer is taken, so
/// a read through a handle and the next draft's write are checked for a happens-before edge.
pub(crate) struct DataCell<T> {
    #[cfg(not(loom))]
    cell: core::cell::UnsafeCell<T>,
    #[cfg(loom)]
    cell: loom::cell::UnsafeCell<T>,
}

impl<T> DataCell<T> {
    #[cfg(not(loom))]
    pub(crate) const fn new(value: T) -> Self {
        DataCell { cell: core::cell::UnsafeCell::new(value) }
    }
    #[cfg(loom)]
    pub(crate) fn new(value: T) -> Self {
        DataCell { cell: loom::cell::UnsafeCell::new(value) }
    }

    #[inline(always)]
    pub(crate) fn read_ptr(&self) -> *const T {
        #[cfg(not(loom))]
        return self.cell.get();
        #[cfg(loom)]
        return self.cell.with(|p| p);
    }

    #[inline(always)]
    pub(crate) fn write_ptr(&self) -> *mut T {
        #[cfg(not(loom))]
        return self.cell.get();
        #[cfg(loom)]
        return self.cell.with_mut(|p| p);
    }
}

#[cfg(not(loom))]
impl<T> DataCell<core::mem::MaybeUninit<T>> {
    /// A cell to be written before use (`Pool::new` fills every slot).
    pub(crate) const fn uninit() -> Self {
        Self::new(core::mem::MaybeUninit::uninit())
    }
}

/// The waker of the publisher waiting for a slot, behind a lock.
pub(crate) struct WakerSlot {
    #[cfg(not(loom))]
    lock: embassy_sync::blocking_mutex::Mutex<
        embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex,
        core::cell::RefCell<WakerRegistration>,
    >,
    #[cfg(loom)]
    lock: loom::sync::Mutex<WakerRegistration>,
}

impl WakerSlot {
    #[cfg(not(loom))]
    pub(crate) const fn new() -> Self {
        WakerSlot {
            lock: embassy_sync::blocking_mutex::Mutex::new(core::cell::RefCell::new(
                WakerRegistration::new(),
            )),
        }
    }
    #[cfg(loom)]
    pub(crate) fn new() -> Self {
        WakerSlot { lock: loom::sync::Mutex::new(WakerRegistration::new()) }
    }

    /// Runs `f` on the registration, under the lock.
    pub(crate) fn with<R>(&self, f: impl FnOnce(&mut WakerRegistration) -> R) -> R {
        #[cfg(not(loom))]
        return self.lock.lock(|w| f(&mut w.borrow_mut()));
        #[cfg(loom)]
        return f(&mut self.lock.lock().unwrap());
    }
}
