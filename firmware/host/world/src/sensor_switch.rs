//! The proximity board's sensor supply switch (hardware/proximity, revision B): a TPS2553
//! current-limited switch between the bus and the four sensor jacks, enabled by
//! `SENSOR_PWR_EN`, with an active-low over-current flag on `SENSOR_PWR_FAULT`.
//!
//! Model: while enabled, the switch passes the sensors' current up to its limit. A demand
//! above the limit (too many or too hungry sensors, or a short on the sensor rail, injected
//! with [`SensorSwitch::set_shorted`]) puts it in current limit: it delivers the limit, the
//! rail collapses below what the sensors run on (they read 0 V, as if unpowered), and the
//! flag is low until the overload goes. The datasheet's 7.5 ms deglitch and thermal cycling
//! are below the world's interest (the firmware reads the flag once a millisecond).

/// The switch's current limit, A: TPS2553 with R_ILIM = 174 kΩ, nominal (132–182 mA over
/// tolerance; `scripts/r2ptools/kicad/modules/proximity.py` prints the numbers).
pub const SENSOR_SWITCH_LIMIT_A: f64 = 0.155;

/// State of one proximity board's sensor switch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorSwitch {
    /// `SENSOR_PWR_EN` (its reset level is on: the board file's `init = "high"`).
    pub enabled: bool,
    shorted: bool,
    limiting: bool,
    load_a: f64,
}

impl Default for SensorSwitch {
    fn default() -> Self {
        Self { enabled: true, shorted: false, limiting: false, load_a: 0.0 }
    }
}

impl SensorSwitch {
    /// Injects (or clears) a short from the sensor rail to ground.
    pub fn set_shorted(&mut self, shorted: bool) {
        self.shorted = shorted;
    }

    /// Whether a short is injected.
    pub fn shorted(&self) -> bool {
        self.shorted
    }

    /// Settles the switch for the connected sensors' `demand_a` with the bus `bus_on`; returns
    /// whether the sensor rail is up (the sensors powered).
    pub fn settle(&mut self, demand_a: f64, bus_on: bool) -> bool {
        let on = self.enabled && bus_on;
        self.limiting = on && (self.shorted || demand_a > SENSOR_SWITCH_LIMIT_A);
        self.load_a = match (on, self.limiting) {
            (false, _) => 0.0,
            (true, true) => SENSOR_SWITCH_LIMIT_A,
            (true, false) => demand_a,
        };
        on && !self.limiting
    }

    /// Whether the switch is holding its current limit (the fault flag asserted).
    pub fn fault(&self) -> bool {
        self.limiting
    }

    /// Current the switch passes from the bus, A, as last settled: the sensors' demand, the
    /// limit while limiting, nothing while off.
    pub fn load_a(&self) -> f64 {
        self.load_a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_sharp_sensors_run_a_fifth_load_or_a_short_trips_the_flag() {
        let mut s = SensorSwitch::default();
        assert!(s.settle(0.033 + 3.0 * 0.030, true) && !s.fault());
        assert!(s.settle(4.0 * 0.033, true) && !s.fault());
        assert!(!s.settle(0.200, true) && s.fault());
        assert_eq!(s.load_a(), SENSOR_SWITCH_LIMIT_A);
        s.set_shorted(true);
        assert!(!s.settle(0.0, true) && s.fault());
        s.enabled = false;
        assert!(
            !s.settle(0.0, true) && !s.fault() && s.load_a() == 0.0,
            "off: no current, no flag"
        );
        s.enabled = true;
        assert!(!s.settle(0.0, false) && !s.fault(), "no bus: no flag");
        s.set_shorted(false);
        assert!(s.settle(0.060, true) && !s.fault());
    }
}
