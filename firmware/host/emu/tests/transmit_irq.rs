//! A board's transmit interrupt as the firmware arms it (rtcan-bxcan's `TransmitWake`): it
//! masks itself when it fires and the bus task unmasks it after the call it woke, so a frame
//! of the board's that leaves its mailbox during that call wakes the bus task at the call's
//! end, not before; and its staged loads run by the firmware's rule then.

use std::cell::RefCell;
use std::rc::Rc;

use r2p_emu::boards::Mcu;
use r2p_emu::{Mode, Runtime, Sim};
use r2p_vbus::Config;
use rtcan::controller::{StagedFrame, TxMode};
use rtcan::{CanController, Frame, Micros};

/// Scripted firmware: at its tick at `tick_us` it loads `first` and stages `staged` behind
/// it; each short path (transmit wake) records its µs and stages `next`.
struct Scripted {
    tick_us: Micros,
    first: Frame,
    staged: Option<Frame>,
    next: Option<Frame>,
    one_shot: bool,
    short_paths: Rc<RefCell<Vec<Micros>>>,
}

const FAR: Micros = 1_000_000;

impl Runtime for Scripted {
    fn poll(&mut self, _: Micros, _: &mut dyn CanController) {}
    fn slot_tick(&mut self, now: Micros, can: &mut dyn CanController) {
        if now == self.tick_us {
            if self.one_shot {
                can.set_tx_mode(TxMode::OneShot);
            }
            can.try_transmit(&self.first).unwrap();
            if let Some(frame) = self.staged.take() {
                can.stage(&[StagedFrame { frame, latest: FAR }]);
            }
        }
    }
    fn next_slot_at(&self, now: Micros) -> Micros {
        if now < self.tick_us {
            self.tick_us
        } else {
            FAR
        }
    }
    fn wakes_on_transmit(&self) -> bool {
        true
    }
    fn top_up(&mut self, now: Micros, can: &mut dyn CanController) {
        can.staged_loaded();
        while can.take_tx_result().is_some() {}
        self.short_paths.borrow_mut().push(now);
        if let Some(frame) = self.next.take() {
            can.stage(&[StagedFrame { frame, latest: FAR }]);
        }
    }
}

fn frame(raw: u32) -> Frame {
    Frame::from_raw(raw, &[0x55; 8]).unwrap()
}

#[test]
fn a_frame_that_loses_its_arbitration_during_the_call_wakes_the_bus_task_at_the_calls_end() {
    // Board 0 sends A, then B one-shot (staged: its transmit interrupt loads B when A ends).
    // Board 1's frame, a lower identifier, waits behind A: B loses to it in its first bits,
    // while board 0's bus task is still in the call A's end woke.
    let calls = Rc::new(RefCell::new(Vec::new()));
    let mut sim: Sim<'static, Box<dyn Runtime>> = Sim::new(2, Config::default(), Mode::Tdma);
    let a = Scripted {
        tick_us: 1_000,
        first: frame(0x1000_0000),
        staged: Some(frame(0x1000_0001)),
        next: Some(frame(0x1000_0002)),
        one_shot: true,
        short_paths: calls.clone(),
    };
    let b = Scripted {
        tick_us: 1_040,
        first: frame(0x0000_0001),
        staged: None,
        next: None,
        one_shot: false,
        short_paths: Rc::new(RefCell::new(Vec::new())),
    };
    sim.add_board(Box::new(a), 0, None);
    sim.add_board(Box::new(b), 1, None);
    sim.run_until(3_000_000);

    let sent: Vec<(u64, usize, Frame)> = sim.bus().frames().collect();
    let ids: Vec<u32> = sent.iter().map(|(_, _, f)| f.id().to_raw()).collect();
    assert_eq!(ids, [0x1000_0000, 0x0000_0001], "B lost and the call's staging did not load");
    let calls = calls.borrow();
    let call_us = Mcu::F103.top_up_path_us();
    assert_eq!(calls.len(), 2, "{calls:?}");
    // B's mailbox emptied within the first call: the interrupt, masked, fires when it ends.
    assert_eq!(calls[1] - calls[0], call_us, "{calls:?}");
    assert_eq!(sim.stats().staged_loads, 1, "B; not the frame staged after it lost");
    assert_eq!(sim.stats().deferred_transmit_irqs, 1);
}
