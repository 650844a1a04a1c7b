//! `r2p ui`'s bus thread: one session on the bus (joined, as `r2p topics` joins, so that every
//! module advertises its topics to it), decoded into a [`BusView`] and published as JSON for
//! the page a few times a second. When the bus goes away (the emulated robot or socketcand
//! server stops, the interface goes down) it says so and opens the bus again every second, so
//! the page follows a robot that restarts without reloading.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use serde_json::json;

use crate::error::CliError;
use crate::session::Session;
use crate::ui_actions::Open;
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
/// `open` opens the bus (the command line's, or an in-process one in tests); `view` makes a
/// fresh view for each session.
pub fn run(open: &Open, view: impl Fn() -> BusView, out: &Snapshots, stop: &AtomicBool) {
    let start = Instant::now();
    let mut last_error: Option<String> = None;
    while !stop.load(Ordering::Relaxed) {
        let error = match open() {
            Ok(s) => match watch(s, view(), out, stop, start) {
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
    mut view: BusView,
    out: &Snapshots,
    stop: &AtomicBool,
    start: Instant,
) -> Result<(), CliError> {
    let describe = s.describe();
    if !s.is_trace() {
        s.join()?;
    }
    eprintln!("r2p ui: watching {describe}");
    let mut published = Instant::now() - PUBLISH_EVERY;
    // A trace is read as fast as it goes: its own clock says how long a module was silent.
    let mut trace_now = Duration::ZERO;
    while !stop.load(Ordering::Relaxed) {
        let reports = if s.ended() {
            std::thread::sleep(Duration::from_millis(20));
            Vec::new()
        } else {
            s.step(Duration::from_millis(10))?
        };
        let now = if s.is_trace() {
            for r in &reports {
                view.feed(std::slice::from_ref(r), r.time);
            }
            trace_now = reports.last().map_or(trace_now, |r| r.time);
            trace_now
        } else {
            let now = start.elapsed();
            view.feed(&reports, now);
            now
        };
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
    fn a_bus_that_cannot_be_opened_is_reported_and_tried_again_and_a_trace_is_shown() {
        use crate::link::TraceLink;
        use crate::watch::tests::{heartbeat, management};
        let tries = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let t = tries.clone();
        // Fails once, then opens a trace of two heartbeats of psu 1.5 s apart, then motor's.
        let open = move || -> Result<Session, CliError> {
            if t.fetch_add(1, Ordering::SeqCst) == 0 {
                return Err(CliError::new("no bus yet"));
            }
            let mut frames = management(1, &heartbeat("psu", 1), 0);
            frames.extend(management(2, &heartbeat("motor", 2), 1_000));
            frames.extend(management(2, &heartbeat("motor", 2), 1_500_000));
            Ok(Session::new(Box::new(TraceLink::new("t.log".into(), frames))))
        };
        let snaps = Arc::new(Snapshots::default());
        let stop = Arc::new(AtomicBool::new(false));
        let (s2, st2) = (snaps.clone(), stop.clone());
        let view = || {
            BusView::new(
                Duration::from_secs(1),
                rtcan::LaxityEncoding::Logarithmic { tick_us: 100 },
            )
        };
        let th = std::thread::spawn(move || run(&open, view, &s2, &st2));
        let (n, text) = snaps.next_after(0, Duration::from_secs(10)).unwrap();
        let j: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(
            (j["bus"]["connected"].clone(), j["bus"]["error"].clone()),
            (json!(false), json!("no bus yet"))
        );
        let (_, text) = snaps.next_after(n, Duration::from_secs(10)).unwrap();
        let j: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(j["bus"]["connected"], true, "tried again after a second: {j}");
        assert_eq!(j["bus"]["trace"], true);
        // The trace's own clock: psu silent for 1.5 s at its end is lost, motor is not.
        let state = |name: &str| {
            j["nodes"].as_array().unwrap().iter().find(|n| n["name"] == name).unwrap()["state"]
                .clone()
        };
        assert_eq!((state("psu"), state("motor")), (json!("LOST"), json!("running")));
        stop.store(true, Ordering::Relaxed);
        th.join().unwrap();
        assert_eq!(tries.load(Ordering::SeqCst), 2);
    }
}
