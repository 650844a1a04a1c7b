//! Any bytes from a Zenoh router (the gateway's ROS 2 side): the handshake, frames, pushes,
//! declarations and CDR payloads never panic; malformed input is counted and dropped. The
//! input is split into batches by its own 2-byte length prefixes (as the TCP link splits
//! them); the first two batches answer the handshake, the rest reach the open session through
//! the gateway's bridge (its /cmd_vel CDR decoding included).
#![no_main]

use libfuzzer_sys::fuzz_target;
use r2p_app_gateway::ros::{zid_of, Latest, RosBridge, RosConfig};
use r2p_zenoh::cdr::cdr_to_packed;

fuzz_target!(|data: &[u8]| {
    let cfg = RosConfig { domain: 0, namespace: "", zid: zid_of([7; 12]) };
    let mut bridge = RosBridge::new(&cfg).expect("keys fit");
    let mut out = [0u8; 16 * 1024];
    let mut now = 0u64;
    let _ = bridge.connect(now, &mut out);
    let mut rest = data;
    while rest.len() >= 2 {
        let len = usize::from(u16::from_le_bytes([rest[0], rest[1]])).min(rest.len() - 2);
        let batch = &rest[2..2 + len];
        rest = &rest[2 + len..];
        now += 1000;
        if bridge.receive(now, batch, &mut out).is_err() {
            let _ = bridge.connect(now, &mut out);
        }
        let _ = bridge.take_cmd(now);
        let _ = bridge.poll(now, 0, &Latest::default(), &mut out);
        // Any payload as any R2P type's CDR.
        for t in r2p_zenoh::types::R2P_TYPES {
            let mut packed = [0u8; 1024];
            let _ = cdr_to_packed(t.fields, batch, &mut packed);
        }
    }
});
