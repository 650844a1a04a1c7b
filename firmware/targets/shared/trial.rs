// An image on trial after an update, on an STM32 behind its R2P bootloader (included by the F103
// module images' module-core and by the gateway, so both keep one copy): the bootloader's state
// read at boot, the independent watchdog started on a trial boot only, and the confirmation
// (embassy-boot's `mark_booted`) once the image says it is healthy; the timing is r2p-boot's
// `trial` (sans-IO, tested on the host).

use embassy_boot::{AlignedBuffer, BlockingFirmwareState, State};
use embassy_stm32::peripherals::IWDG;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::Peri;
use embedded_storage::nor_flash::NorFlash;
use r2p_boot::trial::{Trial, Verdict, WATCHDOG_MS};

/// The image's trial: whether it must still confirm itself, and the watchdog that resets it if
/// it hangs before it can.
pub struct Confirmation {
    trial: Trial,
    watchdog: Option<IndependentWatchdog<'static, IWDG>>,
}

/// embassy-boot's state is read and written in the flash's write units (2 bytes on the F1, 4 on
/// the F4), from a buffer aligned as embassy-boot asks.
fn boot_state<'a, S: NorFlash>(
    state: &'a mut S,
    aligned: &'a mut AlignedBuffer<32>,
) -> BlockingFirmwareState<'a, &'a mut S> {
    BlockingFirmwareState::new(state, &mut aligned.0[..S::WRITE_SIZE])
}

impl Confirmation {
    /// At boot, from the bootloader's state partition `state`: just swapped in (its state says
    /// Swap), the image is on trial and the watchdog starts; just rolled back (Revert), the
    /// image tells the bootloader so (an erase of the state page), so the next update may begin.
    pub fn at_boot<S: NorFlash>(state: &mut S, iwdg: Peri<'static, IWDG>, now_ms: u64) -> Self {
        let mut aligned = AlignedBuffer([0; 32]);
        let mut boot = boot_state(state, &mut aligned);
        let read = boot.get_state().ok();
        if read == Some(State::Revert) {
            let _ = boot.mark_booted();
        }
        let on_trial = read == Some(State::Swap);
        let watchdog = on_trial.then(|| {
            let mut w = IndependentWatchdog::new(iwdg, (WATCHDOG_MS * 1000) as u32);
            w.unleash();
            w
        });
        Self { trial: Trial::new(now_ms, on_trial), watchdog }
    }

    /// An image that runs without the bootloader (flashed alone at the flash base): nothing to
    /// confirm, no watchdog. (Not the gateway's: its image always runs behind the bootloader.)
    #[allow(dead_code)]
    pub const fn not_on_trial() -> Self {
        Self { trial: Trial::new(0, false), watchdog: None }
    }

    /// Feeds the watchdog (started on a trial boot only, and fed from then on).
    pub fn feed(&mut self) {
        if let Some(w) = &mut self.watchdog {
            w.pet();
        }
    }

    /// Polled every 100 ms (with [`feed`](Self::feed)): confirms a `healthy` image on trial in
    /// `state` (its page erased and rewritten: the CPU stalls ~20–40 ms), resets one that is out
    /// of time unconfirmed (the bootloader swaps the previous image back). False if confirming
    /// failed (a storage fault: the bootloader still holds the image on trial, so its next
    /// reset rolls it back).
    pub fn poll<S: NorFlash>(&mut self, state: &mut S, now_ms: u64, healthy: bool) -> bool {
        self.feed();
        match self.trial.poll(now_ms, healthy) {
            Verdict::Confirm => {
                let mut aligned = AlignedBuffer([0; 32]);
                boot_state(state, &mut aligned).mark_booted().is_ok()
            }
            Verdict::GiveUp => cortex_m::peripheral::SCB::sys_reset(),
            Verdict::Wait | Verdict::Kept => true,
        }
    }
}
