//! A new image's trial: after a swap, the image is kept only if it confirms itself healthy in
//! time — it joined the bus (its node ID claimed, the master's sync heard) and its self-checks
//! passed. If it cannot (it hangs, faults, or never joins), it resets without confirming and the
//! bootloader swaps the old image back.
//!
//! Sans-IO: the image polls [`Trial::poll`] with the time and its health, and on
//! [`Verdict::Confirm`] marks itself booted (embassy-boot's `mark_booted`); on
//! [`Verdict::GiveUp`] it resets. An image that hangs before it can poll is caught by the
//! independent watchdog it starts at boot with a longer timeout ([`WATCHDOG_MS`]).

/// How long a new image has to confirm itself: joining the bus takes a few heartbeats (about
/// 3 s after the master's first sync), the self-checks less; 15 s leaves a bus master that is
/// itself rebooting time to come back.
pub const CONFIRM_WITHIN_MS: u64 = 15_000;

/// The independent watchdog's timeout during a trial: longer than [`CONFIRM_WITHIN_MS`], so a
/// live image gives up (and says why in its log) before the watchdog resets a hung one. The
/// STM32's IWDG reaches 26 s (LSI 40 kHz, prescaler 256, reload 4095), 32 s on the F4's 32 kHz.
pub const WATCHDOG_MS: u64 = 20_000;

// The watchdog outlasts the trial, and the F1's IWDG reaches it.
const _: () = assert!(WATCHDOG_MS > CONFIRM_WITHIN_MS && WATCHDOG_MS <= 4095 * 256 * 1000 / 40_000);

/// What the image should do now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Healthy: mark this image booted (once).
    Confirm,
    /// Not yet healthy; still within the time.
    Wait,
    /// Out of time: reset without confirming, so the old image comes back.
    GiveUp,
    /// Already confirmed (or not on trial): nothing to do.
    Kept,
}

/// A trial, from the image's first instant.
#[derive(Clone, Copy, Debug)]
pub struct Trial {
    deadline_ms: u64,
    on_trial: bool,
}

impl Trial {
    /// A trial starting at `now_ms`, if the bootloader's state says this image is on trial (it
    /// was just swapped in); otherwise a trial that is already over.
    pub const fn new(now_ms: u64, on_trial: bool) -> Self {
        Self { deadline_ms: now_ms + CONFIRM_WITHIN_MS, on_trial }
    }

    /// Whether the image still has to confirm itself.
    pub const fn on_trial(&self) -> bool {
        self.on_trial
    }

    /// The verdict at `now_ms` for an image that is `healthy` (joined and self-checked) or not.
    pub fn poll(&mut self, now_ms: u64, healthy: bool) -> Verdict {
        if !self.on_trial {
            Verdict::Kept
        } else if healthy && now_ms < self.deadline_ms {
            self.on_trial = false;
            Verdict::Confirm
        } else if now_ms >= self.deadline_ms {
            Verdict::GiveUp
        } else {
            Verdict::Wait
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_healthy_image_confirms_once() {
        let mut t = Trial::new(1_000, true);
        assert_eq!(t.poll(2_000, false), Verdict::Wait);
        assert_eq!(t.poll(4_000, true), Verdict::Confirm);
        assert_eq!(t.poll(5_000, true), Verdict::Kept);
        assert!(!t.on_trial());
    }

    #[test]
    fn an_image_that_is_not_healthy_in_time_gives_up() {
        let mut t = Trial::new(1_000, true);
        assert_eq!(t.poll(1_000 + CONFIRM_WITHIN_MS - 1, false), Verdict::Wait);
        assert_eq!(t.poll(1_000 + CONFIRM_WITHIN_MS, false), Verdict::GiveUp);
        assert_eq!(
            t.poll(1_000 + CONFIRM_WITHIN_MS, true),
            Verdict::GiveUp,
            "too late, even if healthy now"
        );
    }

    #[test]
    fn an_image_not_on_trial_has_nothing_to_do() {
        assert_eq!(Trial::new(0, false).poll(100_000, false), Verdict::Kept);
    }
}
