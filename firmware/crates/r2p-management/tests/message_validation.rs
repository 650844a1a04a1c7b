//! What a decoder must refuse and what it must keep (docs/management.md): names and topics of
//! the full allowed length round-trip, values and bus classes with no meaning are refused with
//! the tag that was wrong, and every bus class of an advertisement round-trips.

use r2p_management::message::ModuleState;
use r2p_management::message::{
    BusClass, DecodeError, Message, Value, ENCODED_MAX, NAME_MAX, TOPIC_MAX, UID_LEN,
};

fn encode(m: &Message) -> heapless::Vec<u8, ENCODED_MAX> {
    let mut buf = [0u8; ENCODED_MAX];
    let n = m.encode(&mut buf).unwrap();
    heapless::Vec::from_slice(&buf[..n]).unwrap()
}

fn heartbeat(name: &str) -> Message {
    Message::Heartbeat {
        uid: [7; UID_LEN],
        name: heapless::String::try_from(name).unwrap(),
        state: ModuleState::Running,
        uptime_s: 12,
        tx_errors: 0,
        rx_errors: 0,
        dropped: 0,
    }
}

fn advertise(topic: &str, class: BusClass) -> Message {
    Message::Advertise {
        topic: heapless::String::try_from(topic).unwrap(),
        type_hash: 0xA1B2_C3D4,
        size: 8,
        index: 2,
        class,
    }
}

#[test]
fn names_and_topics_of_the_full_length_round_trip() {
    let name = "n".repeat(NAME_MAX);
    let m = heartbeat(&name);
    assert_eq!(Message::decode(&encode(&m)), Ok(m));
    let topic = "t/".repeat(TOPIC_MAX / 2);
    let m = advertise(&topic, BusClass::Nrt);
    assert_eq!(Message::decode(&encode(&m)), Ok(m));
}

#[test]
fn a_module_name_with_a_control_character_is_refused() {
    for bad in ["motor\n", "\u{7f}x", "a\tb"] {
        let bytes = encode(&heartbeat(bad));
        assert_eq!(Message::decode(&bytes), Err(DecodeError::BadString), "{bad:?}");
    }
    assert!(Message::decode(&encode(&heartbeat("left wheel ~1"))).is_ok(), "printable ASCII");
}

#[test]
fn every_bus_class_of_an_advertisement_round_trips() {
    for class in [
        BusClass::Hrt { period_cycles: 1 },
        BusClass::Hrt { period_cycles: u16::MAX },
        BusClass::Srt { deadline_us: 0 },
        BusClass::Srt { deadline_us: 5_000 },
        BusClass::Nrt,
    ] {
        let m = advertise("speed", class);
        assert_eq!(Message::decode(&encode(&m)), Ok(m), "{class:?}");
    }
}

/// The advertisement `advertise("speed", Nrt)` with its class tag and argument replaced.
fn advertise_with(tag: u8, arg: u32) -> heapless::Vec<u8, ENCODED_MAX> {
    let mut b = encode(&advertise("speed", BusClass::Nrt));
    let n = b.len();
    b[n - 5] = tag;
    b[n - 4..].copy_from_slice(&arg.to_le_bytes());
    b
}

#[test]
fn bus_classes_with_no_meaning_are_refused() {
    assert_eq!(Message::decode(&advertise_with(2, 0)), Ok(advertise("speed", BusClass::Nrt)));
    assert_eq!(
        Message::decode(&advertise_with(0, 7)),
        Ok(advertise("speed", BusClass::Hrt { period_cycles: 7 }))
    );
    for (tag, arg) in [(0, 0), (0, 0x1_0000), (0, u32::MAX), (2, 1), (2, 5_000), (3, 0)] {
        assert_eq!(
            Message::decode(&advertise_with(tag, arg)),
            Err(DecodeError::BadValue(tag)),
            "class tag {tag} with {arg}"
        );
    }
}

#[test]
fn a_boolean_parameter_value_other_than_0_or_1_is_refused() {
    let m = Message::ParamValue { index: 3, value: Value::Bool(true) };
    let mut b = encode(&m);
    assert_eq!(Message::decode(&b), Ok(m));
    let n = b.len();
    b[n - 4..].copy_from_slice(&2u32.to_le_bytes());
    assert_eq!(Message::decode(&b), Err(DecodeError::BadValue(0)));
}
