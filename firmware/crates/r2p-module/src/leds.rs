//! The three status LEDs every module has (LED_STATUS green, LED_BUS yellow, LED_FAULT red),
//! shown the same way on every module so a user reads any of them alike:
//!
//! | LED    | pattern | meaning |
//! |--------|---------|---------|
//! | status | slow blink (1 Hz) | running, node ID claimed |
//! | status | fast blink (5 Hz) | booting or claiming a node ID |
//! | bus    | on                | following the bus's sync (or sending it, as master) |
//! | bus    | flash on traffic  | frames received without a sync (unslotted bus) |
//! | bus    | off               | no frame for a second, or bus-off |
//! | fault  | on                | a latched fault (cleared by command) |
//! | fault  | fast blink        | parameters could not be stored in flash |

/// A LED's pattern over time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pattern {
    /// Dark.
    Off,
    /// Lit.
    On,
    /// Lit for half of every `period_ms`.
    Blink {
        /// Full period.
        period_ms: u32,
    },
}

/// Slow blink: running.
pub const SLOW: Pattern = Pattern::Blink { period_ms: 1000 };
/// Fast blink: booting, or a storage fault.
pub const FAST: Pattern = Pattern::Blink { period_ms: 200 };

impl Pattern {
    /// Whether the LED is lit at `now_ms`.
    pub fn is_lit(self, now_ms: u64) -> bool {
        match self {
            Self::Off => false,
            Self::On => true,
            Self::Blink { period_ms } => {
                let p = u64::from(period_ms.max(2));
                now_ms % p < p / 2
            }
        }
    }
}

/// What the module is doing, as the LEDs show it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Status {
    /// The node has claimed its node ID.
    pub running: bool,
    /// The node follows (or sends) the bus's sync.
    pub synced: bool,
    /// A frame arrived within the last second.
    pub traffic: bool,
    /// A fault is latched.
    pub fault: bool,
    /// Parameters could not be stored.
    pub storage_fault: bool,
}

/// Levels of (status, bus, fault) LEDs at `now_ms` (true = lit; the board file says which pin
/// level lights them).
pub fn levels(s: Status, now_ms: u64) -> [bool; 3] {
    let status = if s.running { SLOW } else { FAST };
    let bus = if s.synced {
        Pattern::On
    } else if s.traffic {
        FAST
    } else {
        Pattern::Off
    };
    let fault = if s.fault {
        Pattern::On
    } else if s.storage_fault {
        FAST
    } else {
        Pattern::Off
    };
    [status.is_lit(now_ms), bus.is_lit(now_ms), fault.is_lit(now_ms)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_follow_the_table() {
        let lit = |s, t| levels(s, t);
        let run = Status { running: true, synced: true, ..Default::default() };
        assert_eq!(lit(run, 0), [true, true, false]);
        assert_eq!(lit(run, 600), [false, true, false]);
        let boot = Status::default();
        assert_eq!(lit(boot, 150), [false, false, false]);
        assert_eq!(lit(boot, 50), [true, false, false]);
        assert!(lit(Status { fault: true, ..run }, 600)[2]);
        assert!(!lit(Status { storage_fault: true, ..run }, 150)[2]);
    }
}
