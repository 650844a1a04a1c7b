// The bus task's wakes besides its slot timer's compare (included by module-core's and the
// gateway's slot timers, so both keep one copy): on frame-sized reservations (issue 22, the
// including crate's feature `framed-reservations`) one of the node's frames leaving its mailbox
// (`rtcan_bxcan::TransmitWake`) or a publish for the bus (`Node::wake_on_release`) ends the
// slot timer's wait, and the bus task runs `Node::top_up` instead of `Node::slot_tick`. Without
// the feature nothing is ever raised, and the checks compile to nothing.

/// A wake other than the compare since the bus task last looked.
#[cfg(feature = "framed-reservations")]
static EVENT: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

/// What ended the slot timer's `wait_until::<true>`.
#[cfg(feature = "framed-reservations")]
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Woken {
    /// The time asked for came: the node's slot timer (`Node::slot_tick`).
    Timer,
    /// A wake before it: one of the node's frames left its mailbox, or the application
    /// published for the bus (`Node::top_up`).
    Event,
}

/// Notes a wake; the caller then wakes the bus task's waker.
#[cfg(feature = "framed-reservations")]
pub fn raise() {
    EVENT.store(true, core::sync::atomic::Ordering::Release);
}

/// True (and taken) if a wake came since the last look.
#[inline(always)]
pub fn take() -> bool {
    #[cfg(feature = "framed-reservations")]
    return EVENT.swap(false, core::sync::atomic::Ordering::Acquire);
    #[cfg(not(feature = "framed-reservations"))]
    false
}

/// True if a wake came since the last look (left for [`take`]).
#[inline(always)]
pub fn pending() -> bool {
    #[cfg(feature = "framed-reservations")]
    return EVENT.load(core::sync::atomic::Ordering::Acquire);
    #[cfg(not(feature = "framed-reservations"))]
    false
}
