//! The transmit interrupt's staged loads as the bxCAN model runs them
//! ([`BxCanPort::load_staged`]): only after the node's last frame was sent, only into mailboxes
//! whose results were taken, only while each frame may still go, once per staging.

use r2p_vbus::{Bus, BxCanPort, Config, EventKind};
use rtcan::controller::{StagedFrame, TxMode, TxOutcome};
use rtcan::{CanController, Frame};

const BIT_RATE: u32 = 1_000_000;

fn frame(raw: u32) -> Frame {
    Frame::from_raw(raw, &[raw as u8; 8]).unwrap()
}

fn staged(raws: &[u32], latest: u64) -> Vec<StagedFrame> {
    raws.iter().map(|&r| StagedFrame { frame: frame(r), latest }).collect()
}

/// Port 0 with one frame of its own sent at once (its result not taken), the bus idle after.
fn after_one_sent() -> (Bus, BxCanPort) {
    let bus = Bus::new(2, Config::default());
    let mut port = BxCanPort::new(bus.port(0), BIT_RATE);
    port.try_transmit(&frame(0x100)).unwrap();
    bus.advance_to(1_000_000);
    assert_eq!((port.port().pending(), port.port().results_waiting().len()), (0, 1));
    (bus, port)
}

#[test]
fn staged_frames_go_into_the_mailboxes_whose_results_were_taken_in_order() {
    let (_bus, mut port) = after_one_sent();
    port.stage(&staged(&[0x201, 0x202, 0x203], 2_000));
    assert!(port.has_staged());
    // Three staged, three mailboxes, one result waiting: two load, the third would clear it.
    assert_eq!(port.load_staged(1_000), 2);
    assert!(!port.has_staged(), "loaded once: the rest are dropped");
    assert_eq!(port.port().pending(), 2);
    assert_eq!(port.staged_loaded(), 2);
    assert_eq!(port.staged_loaded(), 0, "told once");
    // The result waiting is still the sent frame's.
    assert_eq!(port.take_tx_result().map(|r| (r.id, r.sent())), Some((frame(0x100).id(), true)));
}

#[test]
fn nothing_loads_past_a_frames_latest_start() {
    let (_bus, mut port) = after_one_sent();
    let mut frames = staged(&[0x201, 0x202], 1_500);
    frames[1].latest = 1_000; // the second may no longer go at 1 000 µs: neither may those behind
    port.stage(&frames);
    assert_eq!(port.load_staged(1_000), 1);
    port.stage(&staged(&[0x301], 1_000));
    assert_eq!(port.load_staged(1_000), 0);
    assert_eq!(port.port().pending(), 1);
}

#[test]
fn nothing_loads_after_a_frame_that_did_not_go_out() {
    // One-shot: the node's frame loses its arbitration to port 1's lower identifier.
    let bus = Bus::new(2, Config::default());
    let mut port = BxCanPort::new(bus.port(0), BIT_RATE);
    let mut other = bus.port(1);
    port.set_tx_mode(TxMode::OneShot);
    port.try_transmit(&frame(0x100)).unwrap();
    other.try_transmit(&frame(0x001)).unwrap();
    bus.advance_to(1_000_000);
    assert_eq!(port.port().pending(), 0);
    port.stage(&staged(&[0x201], 2_000));
    assert_eq!(port.load_staged(1_000), 0, "another node's frame follows: the node decides");
    assert_eq!(port.staged_loaded(), 0);
    assert!(!port.has_staged());
}

#[test]
fn a_new_staging_replaces_the_last() {
    let (_bus, mut port) = after_one_sent();
    port.stage(&staged(&[0x201, 0x202], 2_000));
    port.stage(&staged(&[0x301], 2_000));
    assert_eq!(port.load_staged(1_000), 1);
    port.stage(&[]);
    assert!(!port.has_staged());
}

#[test]
fn a_mailbox_write_clears_that_mailboxs_result_and_a_pending_mailbox_takes_none() {
    // What the firmware's interrupt must avoid (it loads only mailboxes whose results were
    // taken), as bxCAN does it: setting TXRQ clears RQCP and TXOK (RM0008 §24.9.2), and the
    // registers of a pending mailbox are write-protected.
    let (_bus, port) = after_one_sent();
    let p = port.port();
    assert_eq!(p.mailboxes(), [(false, Some(TxOutcome::Sent)), (false, None), (false, None)]);
    assert_eq!(p.newest_held(), Some(0), "sent, its result not taken");
    assert!(p.load_mailbox(1, &frame(0x201), 0));
    assert_eq!(p.newest_held(), Some(1));
    assert!(!p.load_mailbox(1, &frame(0x202), 0), "pending");
    assert!(p.load_mailbox(0, &frame(0x203), 0));
    assert_eq!(p.mailboxes(), [(true, None), (true, None), (false, None)], "its result is gone");
    assert_eq!(p.results_waiting(), []);
    assert_eq!((p.pending(), p.newest_held()), (2, Some(0)));
}

#[test]
fn the_status_register_shows_each_mailboxs_last_outcome_until_its_result_is_taken() {
    // Port 0's frame loses a one-shot arbitration to port 1's; its second frame, written with
    // a 40 µs path once the bus is idle, goes out no sooner.
    let bus = Bus::new(2, Config::default());
    let mut port = BxCanPort::new(bus.port(0), BIT_RATE);
    port.set_tx_mode(TxMode::OneShot);
    port.try_transmit(&frame(0x100)).unwrap();
    bus.port(1).try_transmit(&frame(0x001)).unwrap();
    bus.advance_to(60_000);
    let (status, rqcp) = port.transmit_status();
    assert_eq!(rqcp, [true, false, false]);
    assert!(status[0].empty && status[0].alst && !status[0].txok && !status[0].terr);
    assert!(status[1..].iter().all(|s| s.empty && !s.alst && !s.txok && !s.terr));
    bus.advance_to(400_000); // port 1's frame is over: the bus is idle
    assert!(port.port().load_mailbox(1, &frame(0x102), 40_000));
    bus.advance_to(1_000_000);
    let (status, rqcp) = port.transmit_status();
    assert_eq!(rqcp, [true, true, false]);
    assert!(status[1].empty && status[1].txok && !status[1].alst && !status[1].terr);
    assert_eq!(port.take_tx_result().map(|r| r.outcome), Some(TxOutcome::LostArbitration));
    assert_eq!(port.transmit_status().1, [false, true, false], "taken");
    let starts: Vec<u64> = bus
        .trace()
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Sent { start_ns, frame: f, .. } if f == frame(0x102) => Some(start_ns),
            _ => None,
        })
        .collect();
    assert_eq!(starts.len(), 1);
    assert!(starts[0] >= 400_000 + 40_000, "requested 40 µs after the write: {starts:?}");
}
