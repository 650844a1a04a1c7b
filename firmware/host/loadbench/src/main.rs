//! `r2p-loadbench`: the RTCAN-under-load sweep of `make bench`. Prints one JSON object per load
//! point (`"bench": "rtcan_load"`) and a last one with the simulation's own speed
//! (`"bench": "rtcan_load_sim"`); `scripts/r2ptools/bench.py` tabulates and plots them.
//! Wall-clock figures appear only here, never in the library's results.

use std::process::ExitCode;
use std::time::Instant;

use r2p_loadbench::setup::Mix;
use r2p_loadbench::{point, Policy, Setup};
use rtcan::LaxityEncoding;

const USAGE: &str = "usage: r2p-loadbench [--seed N] [--seconds S] [--loads L1,L2,...] [--policies P1,P2,...] [--mix HRT,SRT]
                     [--laxity E:T] [--blocks K] [--laxity-drift N] [--reactions T,R] [--hrt-exact]
                     [--staged] [--hrt-follow]
  --seed N        traffic seed (default 1)
  --seconds S     measured virtual time per load point (default 10)
  --loads ...     offered loads as fractions of 1 Mbit/s (default 0.10,0.15,...,0.95)
  --policies ...  rtcan (the node runtime's default), rtcan_oneshot (one one-shot frame per
                  free slot), rtcan_merged (merged free-slot windows), rtcan_framed (what-if:
                  frame-sized reservations in blocks, fitted windows), fixed (default: rtcan,
                  the free-slot policy rtcan does not use, rtcan_framed, fixed)
  --mix H,S       HRT and SRT shares of the offered load, NRT the rest (default 0.3,0.5)
  --laxity E:T    SRT laxity encoding, log or linear, tick T µs (default log:100)
  --blocks K      rtcan_framed: blocks of HRT reservations per cycle (default 2)
  what-ifs for issue 22's median goal (docs/rtcan.md, \"What the median goal would take\"):
  --laxity-drift N  rtcan_framed: laxity code steps a loaded frame may lag and stay loaded
                  (default 0, as the node runtime)
  --reactions T,R rtcan_framed: µs from a transmit-complete and from a release to the short
                  path's loading (default 27,29: the node runtime's, measured under QEMU)
  --hrt-exact     HRT payloads with no stuff bits and reservations exactly as long as their
                  frames (both protocols' traffic)
  --staged        rtcan_framed: staged reloads (r2p-node's `staged-reloads`): frames staged for
                  the transmit interrupt, loaded 2 µs after the node's frames have left the
                  controller
  --hrt-follow    rtcan_framed: an HRT frame whose reservation follows another's is loaded
                  10 µs after that one's start and goes at its actual end (bounded start
                  jitter: early by the stuff bits the frames before it did not need)
";

struct Args {
    seed: u64,
    seconds: f64,
    loads: Vec<f64>,
    policies: Vec<Policy>,
    mix: Mix,
    laxity: LaxityEncoding,
    blocks: u8,
    laxity_drift: u8,
    reactions_us: (u64, u64),
    hrt_exact: bool,
    staged: bool,
    hrt_follow: bool,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        seed: 1,
        seconds: 10.0,
        loads: (2..=19).map(|k| f64::from(k) / 20.0).collect(),
        policies: Policy::defaults(),
        mix: Setup::new(0.5, 0).mix,
        laxity: Setup::new(0.5, 0).laxity,
        blocks: Setup::new(0.5, 0).hrt_blocks,
        laxity_drift: Setup::new(0.5, 0).laxity_drift,
        reactions_us: Setup::new(0.5, 0).reactions_us,
        hrt_exact: false,
        staged: false,
        hrt_follow: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--help" || flag == "-h" {
            return Err(String::new());
        }
        // Switches: no value.
        let switch = match flag.as_str() {
            "--hrt-exact" => Some(&mut a.hrt_exact),
            "--staged" => Some(&mut a.staged),
            "--hrt-follow" => Some(&mut a.hrt_follow),
            _ => None,
        };
        if let Some(on) = switch {
            *on = true;
            continue;
        }
        const FLAGS: [&str; 9] = [
            "--seed",
            "--seconds",
            "--loads",
            "--policies",
            "--mix",
            "--blocks",
            "--laxity",
            "--laxity-drift",
            "--reactions",
        ];
        if !FLAGS.contains(&flag.as_str()) {
            return Err(format!("unknown option {flag}"));
        }
        let value = it.next().ok_or(format!("{flag} needs a value"))?;
        let bad = |what: &str| format!("{flag} {value}: {what}");
        match flag.as_str() {
            "--seed" => a.seed = value.parse().map_err(|_| bad("not an unsigned integer"))?,
            "--seconds" => {
                a.seconds = value.parse().map_err(|_| bad("not a number"))?;
                if !(a.seconds > 0.0 && a.seconds <= 3600.0) {
                    return Err(bad("must be in (0, 3600]"));
                }
            }
            "--loads" => {
                a.loads = value
                    .split(',')
                    .map(|s| {
                        s.trim().parse::<f64>().map_err(|_| bad(&format!("{s:?} is not a number")))
                    })
                    .collect::<Result<_, _>>()?;
            }
            "--policies" => {
                a.policies = value
                    .split(',')
                    .map(|s| {
                        Policy::from_name(s.trim()).ok_or(bad(&format!("unknown policy {s:?}")))
                    })
                    .collect::<Result<_, _>>()?;
            }
            "--mix" => {
                let v: Vec<f64> = value
                    .split(',')
                    .map(|s| {
                        s.trim().parse::<f64>().map_err(|_| bad(&format!("{s:?} is not a number")))
                    })
                    .collect::<Result<_, _>>()?;
                let [hrt, srt] = v[..] else { return Err(bad("give two shares, HRT,SRT")) };
                a.mix = Mix { hrt, srt };
            }
            "--blocks" => a.blocks = value.parse().map_err(|_| bad("not a block count"))?,
            "--laxity-drift" => {
                a.laxity_drift = value
                    .parse()
                    .ok()
                    .filter(|&n| n < 64)
                    .ok_or(bad("give laxity code steps, 0 … 63"))?;
            }
            "--reactions" => {
                let v: Vec<u64> = value
                    .split(',')
                    .map(|s| s.trim().parse::<u64>().ok().filter(|&us| us > 0))
                    .collect::<Option<_>>()
                    .ok_or(bad("give two positive whole µs, TRANSMIT,RELEASE"))?;
                let [transmit, release] = v[..] else {
                    return Err(bad("give two positive whole µs, TRANSMIT,RELEASE"));
                };
                a.reactions_us = (transmit, release);
            }
            "--laxity" => {
                let (kind, tick) =
                    value.split_once(':').ok_or(bad("write log:TICK or linear:TICK"))?;
                let tick_us = tick
                    .parse()
                    .ok()
                    .filter(|&t| t > 0)
                    .ok_or(bad("tick must be a positive integer (µs)"))?;
                a.laxity = match kind {
                    "log" => LaxityEncoding::Logarithmic { tick_us },
                    "linear" => LaxityEncoding::Linear { tick_us },
                    _ => return Err(bad("the encoding is log or linear")),
                };
            }
            _ => unreachable!("every flag in FLAGS has its arm"),
        }
    }
    Ok(a)
}

fn main() -> ExitCode {
    let args = match parse() {
        Ok(a) => a,
        Err(e) if e.is_empty() => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("r2p-loadbench: {e}\n{USAGE}");
            return ExitCode::FAILURE;
        }
    };
    let t0 = Instant::now();
    let (mut events, mut virtual_s) = (0u64, 0.0);
    for &load in &args.loads {
        let setup = Setup {
            duration_us: (args.seconds * 1e6).round() as u64,
            mix: args.mix,
            laxity: args.laxity,
            hrt_blocks: args.blocks,
            laxity_drift: args.laxity_drift,
            reactions_us: args.reactions_us,
            hrt_exact: args.hrt_exact,
            staged: args.staged,
            hrt_follow: args.hrt_follow,
            ..Setup::new(load, args.seed)
        };
        let t = Instant::now();
        let p = match point(&setup, &args.policies) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("r2p-loadbench: load {load}: {e}");
                return ExitCode::FAILURE;
            }
        };
        let wall = t.elapsed().as_secs_f64();
        let ev: u64 = p.reports.iter().map(|r| r.events).sum();
        events += ev;
        virtual_s += setup.stop_us() as f64 / 1e6 * p.reports.len() as f64;
        let mut json = serde_json::to_value(&p).expect("serializable");
        json["bench"] = "rtcan_load".into();
        json["seed"] = args.seed.into();
        json["seconds"] = args.seconds.into();
        json["mix"] = serde_json::json!({ "hrt": args.mix.hrt, "srt": args.mix.srt });
        json["laxity"] = format!("{:?}", args.laxity).into();
        json["laxity_drift"] = args.laxity_drift.into();
        json["reactions_us"] = serde_json::json!([args.reactions_us.0, args.reactions_us.1]);
        json["hrt_exact"] = args.hrt_exact.into();
        json["staged"] = args.staged.into();
        json["hrt_follow"] = args.hrt_follow.into();
        json["wall_s"] = wall.into();
        json["events_per_s"] = (ev as f64 / wall).round().into();
        println!("{json}");
    }
    let wall = t0.elapsed().as_secs_f64();
    println!(
        "{}",
        serde_json::json!({
            "bench": "rtcan_load_sim",
            "points": args.loads.len(),
            "runs": args.loads.len() * args.policies.len(),
            "virtual_s": virtual_s,
            "wall_s": wall,
            "events": events,
            "events_per_s": (events as f64 / wall).round(),
            "realtime_ratio": virtual_s / wall,
        })
    );
    ExitCode::SUCCESS
}
