//! Host benchmark: publish → deliver → release round trips per second for 1–8 subscribers, on
//! the R2P middleware and on embassy-sync's `PubSubChannel`, in the same process and run.
//! Prints one JSON object per line (`scripts/bench` tabulates them). Timing lives here, never in
//! tests: `make bench` reports numbers and ratios, it does not pass or fail on them.

use std::hint::black_box;
use std::time::Instant;

use r2p_bench::{embassy_round, expected_checksum, r2p_round, SUBSCRIBERS};

const MESSAGES: u32 = 200_000;
const REPEATS: usize = 7;

/// Median messages per second of `REPEATS` timed runs after one warm-up run.
fn rate(round: fn(usize, u32) -> u32, n: usize) -> f64 {
    assert_eq!(round(n, 1000), expected_checksum(n, 1000), "warm-up delivered wrong messages");
    let mut rates: Vec<f64> = (0..REPEATS)
        .map(|_| {
            let t0 = Instant::now();
            black_box(round(black_box(n), black_box(MESSAGES)));
            MESSAGES as f64 / t0.elapsed().as_secs_f64()
        })
        .collect();
    rates.sort_by(|a, b| a.total_cmp(b));
    rates[REPEATS / 2]
}

fn main() {
    for n in SUBSCRIBERS {
        let ours = rate(r2p_round, n);
        let baseline = rate(embassy_round, n);
        println!(
            "{{\"bench\":\"host_pubsub\",\"subscribers\":{n},\"r2p_msgs_per_s\":{ours:.0},\"embassy_sync_msgs_per_s\":{baseline:.0}}}"
        );
    }
}
