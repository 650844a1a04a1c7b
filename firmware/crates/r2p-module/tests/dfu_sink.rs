//! The module's side of an update (`DfuSink`) on its own, over emulated flash: what it answers,
//! what it marks, what it refuses and why (the whole update, swap and power cuts included, is in
//! r2p-boot's tests/power_cuts.rs and the emulated robot's tests/update.rs).

use r2p_boot::boot_state::{self, BootState};
use r2p_boot::sign::{public_key, sign, Meta};
use r2p_boot::transfer::{Msg, State, Status, BLOCK_MAX};
use r2p_boot::{verify_slot, Expect, Refusal, Version};
use r2p_module::{DfuSink, RamFlash};
use r2p_node::UpdateSink;

const SLOT: u32 = 54 * 1024;
const SEED: [u8; 32] = [0x33; 32];
type Dfu = RamFlash<{ 55 * 1024 }, 1024>;
type StatePage = RamFlash<1024, 1024>;
type Sink = DfuSink<Dfu, StatePage>;

fn check(dfu: &mut Dfu) -> Result<(), Refusal> {
    let key = public_key(&SEED);
    verify_slot(dfu, 0, SLOT, &Expect { mcu: "STM32F103CB", kind: None, public_key: &key })
        .map(|_| ())
}

fn sink() -> Sink {
    DfuSink::new("motor", SLOT, Dfu::new(), StatePage::new(), check)
}

fn image(kind: &str) -> Vec<u8> {
    let bytes: Vec<u8> = (0..5_000u32).map(|i| (i * 7 + 3) as u8).collect();
    let meta = Meta { version: Version { major: 2, minor: 0, patch: 1 }, kind, mcu: "STM32F103CB" };
    sign(&bytes, &meta, &SEED).unwrap()
}

fn send(sink: &Sink, msg: Msg<'_>) -> Status {
    let mut buf = [0u8; 64];
    let n = msg.encode(&mut buf);
    let mut answer = [0u8; 64];
    let a = sink.handle(9, &buf[..n], &mut answer);
    match Msg::decode(&answer[..a]) {
        Ok(Msg::Status(s)) => s,
        other => panic!("not a status: {other:?}"),
    }
}

/// Sends the whole of `signed` as transfer `id`; the status after `End`.
fn transfer(sink: &Sink, signed: &[u8], id: u16) -> Status {
    send(sink, Msg::Begin { id, len: signed.len() as u32 });
    for (i, block) in signed.chunks(BLOCK_MAX).enumerate() {
        send(sink, Msg::Block { id, offset: (i * BLOCK_MAX) as u32, data: block });
    }
    send(sink, Msg::End { id })
}

fn state(sink: &Sink) -> BootState {
    sink.with_state(|s| boot_state::read(s, 0).unwrap())
}

#[test]
fn a_verified_image_is_marked_for_the_swap() {
    let sink = sink();
    assert_eq!(state(&sink), BootState::Booted);
    let s = transfer(&sink, &image("motor"), 1);
    assert_eq!((s.state, s.received as usize), (State::Verified, image("motor").len()));
    assert!(sink.is_marked());
    assert_eq!(state(&sink), BootState::Swapped, "embassy-boot's swap magic");
}

#[test]
fn an_image_for_another_kind_is_refused_and_not_marked() {
    let sink = sink();
    assert_eq!(transfer(&sink, &image("psu"), 1).state, State::Refused(Refusal::WrongKind));
    assert!(!sink.is_marked());
    assert_eq!(state(&sink), BootState::Booted);
}

#[test]
fn a_new_transfer_takes_the_mark_back_before_it_overwrites_the_slot() {
    let sink = sink();
    transfer(&sink, &image("motor"), 1);
    assert_eq!(state(&sink), BootState::Swapped);
    let s = send(&sink, Msg::Begin { id: 2, len: 4_000 });
    assert_eq!(s.state, State::Receiving);
    assert!(!sink.is_marked());
    assert_eq!(state(&sink), BootState::Booted, "a reset now must not swap half an image in");
}

#[test]
fn an_image_on_trial_takes_no_update() {
    let sink = sink();
    // The bootloader just swapped this image in: its state still says swap until it confirms.
    sink.with_state(|s| boot_state::mark_updated(s, 0, 1024).unwrap());
    let s = send(&sink, Msg::Begin { id: 3, len: 4_000 });
    assert_eq!(s, Status { id: 3, state: State::Refused(Refusal::OnTrial), received: 0 });
}

#[test]
fn what_is_not_a_senders_transfer_message_is_counted_and_dropped() {
    let sink = sink();
    let mut answer = [0u8; 64];
    assert_eq!(sink.handle(9, &[0x99, 1, 2], &mut answer), 0);
    let mut status = [0u8; 64];
    let n = Msg::Status(Status { id: 1, state: State::Idle, received: 0 }).encode(&mut status);
    assert_eq!(sink.handle(9, &status[..n], &mut answer), 0, "a status is the module's own");
    assert_eq!(sink.malformed(), 2);
}
