// An image on trial after an update, on an STM32 behind its R2P bootloader (included by the F103
// module images' module-core and by the gateway, so both keep one copy): the bootloader's state
// read at boot, the independent watchdog started on a trial boot only, and the confirmation
// once the image says it is healthy. The timing is r2p-boot's `trial`, the state embassy-boot's
// through r2p-boot's `boot_state` (both tested on the host).

use embassy_stm32::peripherals::IWDG;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::Peri;
use embedded_storage::nor_flash::NorFlash;
use r2p_boot::boot_state::{self, BootState};
use r2p_boot::layout::Partition;
use r2p_boot::trial::{Trial, Verdict, WATCHDOG_MS};

/// The image's trial: whether it must still confirm itself, where (the bootloader's state
/// partition), and the watchdog that resets it if it hangs before it can.
pub struct Confirmation {
    trial: Trial,
    state: Partition,
    watchdog: Option<IndependentWatchdog<'static, IWDG>>,
}

impl Confirmation {
    /// At boot, from the bootloader's `state` partition in `flash`: just swapped in, the image
    /// is on trial and the watchdog starts; just rolled back, the image tells the bootloader so
    /// (an erase of the state page), so the next update may begin.
    pub fn at_boot<F: NorFlash>(
        flash: &mut F,
        state: Partition,
        iwdg: Peri<'static, IWDG>,
        now_ms: u64,
    ) -> Self {
        let read = boot_state::read(flash, state.offset).ok();
        if read == Some(BootState::Reverted) {
            let _ = boot_state::mark_booted(flash, state.offset, state.size);
        }
        let on_trial = read == Some(BootState::Swapped);
        let watchdog = on_trial.then(|| {
            let mut w = IndependentWatchdog::new(iwdg, (WATCHDOG_MS * 1000) as u32);
            w.unleash();
            w
        });
        Self { trial: Trial::new(now_ms, on_trial), state, watchdog }
    }

    /// An image that runs without the bootloader (flashed alone at the flash base): nothing to
    /// confirm, no watchdog. (Not the gateway's: its image always runs behind the bootloader.)
    #[allow(dead_code)]
    pub const fn not_on_trial() -> Self {
        Self {
            trial: Trial::new(0, false),
            state: Partition { offset: 0, size: 0 },
            watchdog: None,
        }
    }

    /// Feeds the watchdog (started on a trial boot only, and fed from then on).
    pub fn feed(&mut self) {
        if let Some(w) = &mut self.watchdog {
            w.pet();
        }
    }

    /// Polled every 100 ms (with [`feed`](Self::feed)): confirms a `healthy` image on trial in
    /// the state partition of `flash` (its page erased and rewritten: the CPU stalls ~20–40 ms),
    /// resets one that is out of time unconfirmed (the bootloader swaps the previous image
    /// back). False if confirming failed (a storage fault: the bootloader still holds the image
    /// on trial, so its next reset rolls it back).
    pub fn poll<F: NorFlash>(&mut self, flash: &mut F, now_ms: u64, healthy: bool) -> bool {
        self.feed();
        match self.trial.poll(now_ms, healthy) {
            Verdict::Confirm => {
                boot_state::mark_booted(flash, self.state.offset, self.state.size).is_ok()
            }
            Verdict::GiveUp => cortex_m::peripheral::SCB::sys_reset(),
            Verdict::Wait | Verdict::Kept => true,
        }
    }
}
