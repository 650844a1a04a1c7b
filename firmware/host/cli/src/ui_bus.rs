//! `r2p ui`'s bus thread: one session on the bus (joined, as `r2p topics` joins, so that every
//! module advertises its topics to it), decoded into a [`BusView`] and published as JSON for
//! the page a few times a second. When the bus goes away (the emulated robot or socketcand
//! server stops, the interface goes down) it says so and opens the bus again every second, so
//! the page follows a robot that restarts without reloading.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use serde_json::json;

use crate::args::{open_link, BusArgs};
use crate::error::CliError;
use crate::session::Session;
use crate::ui_view::BusView;

/// How often the page gets a new snapshot.
pub const PUBLISH_EVERY: Duration = Duration::from_millis(200);
/// How long to wait before opening a bus that failed again.
pub const RETRY_EVERY: Duration = Duration::from_secs(1);

/// The latest snapshot (numbered, as JSON text), shared with the page's event streams.
#[derive(Default)]
pub struct Snapshots {
    latest: Mutex<(u64, String)>,
    changed: Condvar,
}

impl Snapshots {
    /// Replaces the snapshot and wakes the streams.
    pub fn publish(&self, text: String) {
        let mut l = self.latest.lock().unwrap_or_else(|e| e.into_inner());
        *l = (l.0 + 1, text);
        self.changed.notify_all();
    }

    /// The snapshot after number `seen` (waiting up to `wait` for one), with its number.
    pub fn next_after(&self, seen: u64, wait: Duration) -> Option<(u64, String)> {
        let l = self.latest.lock().unwrap_or_else(|e| e.into_inner());
        let (l, _) = self
            .changed
            .wait_timeout_while(l, wait, |l| l.0 <= seen)
            .unwrap_or_else(|e| e.into_inner());
        (l.0 > seen).then(|| l.clone())
    }
}

/// Runs the bus loop until `stop`: publishes a snapshot every [`PUBLISH_EVERY`], with the
/// bus's state (`connected`, or the error that closed it while it is opened again).
pub fn run(bus: &BusArgs, lost_after: Duration, out: &Snapshots, stop: &AtomicBool) {
    let start = Instant::now();
    let mut last_error: Option<String> = None;
    while !stop.load(Ordering::Relaxed) {
        let error = match open_link(bus) {
            Ok(link) => match watch(Session::new(link), lost_after, out, stop, start) {
                Ok(()) => return,
                Err(e) => e,
            },
            Err(e) => e,
        };
        let text = error.to_string();
        if last_error.as_ref() != Some(&text) {
            eprintln!("r2p ui: {text}; opening the bus again every {RETRY_EVERY:?}");
        }
        let j = json!({
            "bus": {"connected": false, "error": text, "at_s": start.elapsed().as_secs_f64()},
        });
        out.publish(j.to_string());
        last_error = Some(text);
        let t0 = Instant::now();
        while t0.elapsed() < RETRY_EVERY && !stop.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// Watches one session until `stop` (Ok) or until the bus fails (the error).
fn watch(
    mut s: Session,
    lost_after: Duration,
    out: &Snapshots,
    stop: &AtomicBool,
    start: Instant,
) -> Result<(), CliError> {
    let describe = s.describe();
    if !s.is_trace() {
        s.join()?;
    }
    eprintln!("r2p ui: watching {describe}");
    let mut view = BusView::new(lost_after);
    let mut published = Instant::now() - PUBLISH_EVERY;
    while !stop.load(Ordering::Relaxed) {
        let reports = if s.ended() {
            std::thread::sleep(Duration::from_millis(20));
            Vec::new()
        } else {
            s.step(Duration::from_millis(10))?
        };
        let now = start.elapsed();
        view.feed(s.watcher(), &reports, now);
        if published.elapsed() >= PUBLISH_EVERY {
            let own = s.host().map(|h| h.node_id().get());
            let mut j = view.snapshot(s.watcher(), now, own);
            j["bus"] = json!({
                "connected": true, "describe": describe, "trace": s.is_trace(),
                "ended": s.ended(), "own_node": own, "at_s": now.as_secs_f64(),
            });
            out.publish(j.to_string());
            published = Instant::now();
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn streams_get_each_newer_snapshot_or_nothing_after_the_wait() {
        let s = Arc::new(Snapshots::default());
        assert_eq!(s.next_after(0, Duration::from_millis(10)), None);
        s.publish("a".into());
        assert_eq!(s.next_after(0, Duration::ZERO), Some((1, "a".into())));
        assert_eq!(s.next_after(1, Duration::from_millis(10)), None);
        let s2 = s.clone();
        let t = std::thread::spawn(move || s2.next_after(1, Duration::from_secs(10)));
        std::thread::sleep(Duration::from_millis(20));
        s.publish("b".into());
        assert_eq!(t.join().unwrap(), Some((2, "b".into())));
    }

    #[test]
    fn a_bus_that_cannot_be_opened_is_reported_and_tried_again() {
        // Port 9 on loopback: nothing listens.
        let bus = BusArgs {
            socketcand: Some("127.0.0.1:9".into()),
            socketcan: None,
            trace: None,
            channel: "vcan0".into(),
            timeout: Duration::from_secs(1),
            json: false,
        };
        let snaps = Arc::new(Snapshots::default());
        let stop = Arc::new(AtomicBool::new(false));
        let (s2, st2) = (snaps.clone(), stop.clone());
        let t = std::thread::spawn(move || run(&bus, Duration::from_secs(1), &s2, &st2));
        let (n, text) = snaps.next_after(0, Duration::from_secs(10)).unwrap();
        let j: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(j["bus"]["connected"], false);
        assert!(j["bus"]["error"].as_str().unwrap().contains("127.0.0.1:9"), "{j}");
        let again = snaps.next_after(n, Duration::from_secs(10));
        assert!(again.is_some(), "tried again after a second");
        stop.store(true, Ordering::Relaxed);
        t.join().unwrap();
    }
}
