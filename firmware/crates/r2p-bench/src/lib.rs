//! Benchmark workloads, the same code on the host and on a Cortex-M3 under QEMU.
//!
//! One message round trip: the publisher takes a message, fills it, publishes it; every one
//! of `n` subscribers (queue length 1) receives it and drops it; the message is free again.
//! [`r2p_round`] does it with the R2P middleware (zero copy, reference counted), [`embassy_round`]
//! with embassy-sync's `PubSubChannel` (each subscriber gets a copy) — the baseline the issue
//! asks for, measured in the same run. Each returns a checksum of what the subscribers read, so
//! the optimiser cannot drop the work and a broken delivery shows in the result.
#![no_std]
#![warn(missing_docs)]

use core::sync::atomic::{AtomicBool, Ordering};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pubsub::PubSubChannel;
use r2p_middleware::{pool_size, Class, Publisher, Subscriber, Topic};

/// The message benchmarked: 16 bytes, like a `Battery` reading.
#[derive(Clone, Copy, Default)]
pub struct Payload(pub [u32; 4]);

/// Subscriber counts benchmarked.
pub const SUBSCRIBERS: [usize; 8] = [1, 2, 3, 4, 5, 6, 7, 8];

macro_rules! rounds {
    ($($n:literal => $r2p:ident, $emb:ident;)*) => {
        $(
            /// `messages` round trips with this many subscribers on the R2P middleware.
            #[inline(never)]
            pub fn $r2p(messages: u32) -> u32 {
                // Topics are statics by design (they hand out `'static` handles); each subscriber
                // count gets its own, wired once.
                static SUBS: [Subscriber<'static, Payload, 1>; $n] = [const { Subscriber::new() }; $n];
                static TOPIC: Topic<'static, Payload, { pool_size(&[1; $n], 1) }, $n> =
                    Topic::new("bench", Payload([0; 4]));
                static PUBLISHER: Publisher<'static, Payload> = Publisher::new(&TOPIC, Class::NonRealTime);
                static WIRED: AtomicBool = AtomicBool::new(false);
                if !WIRED.swap(true, Ordering::Relaxed) {
                    TOPIC.advertise(&PUBLISHER).unwrap();
                    for s in &SUBS {
                        TOPIC.subscribe(s).unwrap();
                    }
                }
                let mut sum = 0u32;
                for i in 0..messages {
                    let mut m = PUBLISHER.try_alloc().unwrap();
                    m.0[0] = i;
                    PUBLISHER.publish(m);
                    for s in &SUBS {
                        sum = sum.wrapping_add(s.try_recv().unwrap().0[0]);
                    }
                }
                sum
            }

            /// `messages` round trips with this many subscribers on embassy-sync's PubSubChannel.
            #[inline(never)]
            pub fn $emb(messages: u32) -> u32 {
                let channel: PubSubChannel<CriticalSectionRawMutex, Payload, 1, $n, 1> = PubSubChannel::new();
                let publisher = channel.immediate_publisher();
                let mut subs: [_; $n] = core::array::from_fn(|_| channel.subscriber().unwrap());
                let mut sum = 0u32;
                for i in 0..messages {
                    publisher.publish_immediate(Payload([i, 0, 0, 0]));
                    for s in subs.iter_mut() {
                        sum = sum.wrapping_add(s.try_next_message_pure().unwrap().0[0]);
                    }
                }
                sum
            }
        )*

        /// The R2P round for `n` subscribers (1–8).
        pub fn r2p_round(n: usize, messages: u32) -> u32 {
            match n { $($n => $r2p(messages),)* _ => panic!("1 to 8 subscribers") }
        }

        /// The embassy-sync round for `n` subscribers (1–8).
        pub fn embassy_round(n: usize, messages: u32) -> u32 {
            match n { $($n => $emb(messages),)* _ => panic!("1 to 8 subscribers") }
        }
    };
}

rounds! {
    1 => r2p_1, embassy_1;
    2 => r2p_2, embassy_2;
    3 => r2p_3, embassy_3;
    4 => r2p_4, embassy_4;
    5 => r2p_5, embassy_5;
    6 => r2p_6, embassy_6;
    7 => r2p_7, embassy_7;
    8 => r2p_8, embassy_8;
}

/// What a round's checksum must be: each subscriber reads 0, 1, …, messages − 1.
pub fn expected_checksum(n: usize, messages: u32) -> u32 {
    let per_sub = (0..messages).fold(0u32, |a, i| a.wrapping_add(i));
    per_sub.wrapping_mul(n as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_implementations_deliver_every_message_to_every_subscriber() {
        for n in SUBSCRIBERS {
            assert_eq!(r2p_round(n, 100), expected_checksum(n, 100), "r2p, {n} subscribers");
            assert_eq!(
                embassy_round(n, 100),
                expected_checksum(n, 100),
                "embassy, {n} subscribers"
            );
        }
    }
}
