//! Quadrature encoder on the motor shaft, counted by an MCU timer in encoder mode.
//!
//! An incremental encoder of `cpr` lines gives 4·cpr edges per revolution on A and B; the
//! STM32 timer in encoder mode (TIM3 on the motor module) counts every edge up or down by
//! direction in a 16-bit register that wraps, which is what the firmware reads and extends to
//! 32 bits. The count is a function of the shaft angle (edge k at angle k·2π/(4·cpr)), so no
//! edges are lost however fast the shaft turns between reads (edges lie half a count either
//! side of angle 0, then every 2π/(4·cpr)); the firmware must still read
//! often enough to unwrap the 16-bit value (below 32 768 counts between reads).
//!
//! Fault: a disconnected encoder (cable off: A and B pulled up, no edges) freezes the count;
//! on reconnection counting resumes from the frozen value.

/// A quadrature encoder and the 16-bit timer counting it.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoder {
    /// Lines per revolution (counts per revolution before ×4 decoding).
    pub cpr: u32,
    /// Whether positive shaft rotation counts down (A/B swapped).
    pub inverted: bool,
    connected: bool,
    /// Edge index of the shaft angle at the last update.
    edges: i64,
    /// Edges counted by the timer (unbounded; the register holds its low 16 bits).
    count: i64,
}

impl Encoder {
    /// An encoder of `cpr` lines at shaft angle `angle` with the timer at 0.
    pub fn new(cpr: u32, angle: f64) -> Self {
        let mut e = Self { cpr, inverted: false, connected: true, edges: 0, count: 0 };
        e.edges = e.edge_index(angle);
        e
    }

    /// Edges per revolution (4 × cpr).
    pub fn counts_per_rev(&self) -> u32 {
        4 * self.cpr
    }

    /// Edges passed at `angle`: the disc's phase puts the shaft at rest at angle 0 midway
    /// between two edges, so that a shaft at rest never sits on an edge.
    fn edge_index(&self, angle: f64) -> i64 {
        (angle * f64::from(self.counts_per_rev()) / std::f64::consts::TAU + 0.5).floor() as i64
    }

    /// Follows the shaft to `angle` (rad, unwrapped).
    pub fn update(&mut self, angle: f64) {
        let e = self.edge_index(angle);
        if self.connected {
            let d = e - self.edges;
            self.count += if self.inverted { -d } else { d };
        }
        self.edges = e;
    }

    /// The timer register: the count modulo 2^16.
    pub fn hardware_count(&self) -> u16 {
        self.count.rem_euclid(1 << 16) as u16
    }

    /// Whether the encoder is connected.
    pub fn connected(&self) -> bool {
        self.connected
    }

    /// Connects or disconnects the encoder (fault injection).
    pub fn set_connected(&mut self, connected: bool) {
        self.connected = connected;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    #[test]
    fn one_revolution_is_four_times_cpr() {
        let mut e = Encoder::new(500, 0.0);
        e.update(TAU);
        assert_eq!(e.hardware_count(), 2000);
        // Edges lie half a count either side of each count's centre.
        e.update(TAU + 0.49 * TAU / 2000.0);
        assert_eq!(e.hardware_count(), 2000);
        e.update(TAU + 0.51 * TAU / 2000.0);
        assert_eq!(e.hardware_count(), 2001);
        e.update(TAU - 0.51 * TAU / 2000.0);
        assert_eq!(e.hardware_count(), 1999);
    }

    #[test]
    fn sixteen_bit_register_wraps_both_ways() {
        let mut e = Encoder::new(500, 0.0);
        e.update(40.0 * TAU); // 80 000 counts
        assert_eq!(e.hardware_count(), (80_000 - 65_536) as u16);
        let mut e = Encoder::new(500, 0.0);
        e.update(-TAU / 2000.0); // one edge backwards
        assert_eq!(e.hardware_count(), 65_535);
    }

    #[test]
    fn inverted_counts_down() {
        let mut e = Encoder::new(500, 0.0);
        e.inverted = true;
        e.update(TAU / 4.0);
        assert_eq!(e.hardware_count(), (65_536 - 500) as u16);
    }

    #[test]
    fn disconnection_freezes_then_resumes() {
        let mut e = Encoder::new(500, 0.0);
        e.update(TAU / 2.0);
        assert_eq!(e.hardware_count(), 1000);
        e.set_connected(false);
        e.update(3.0 * TAU);
        assert_eq!(e.hardware_count(), 1000, "frozen while disconnected");
        e.set_connected(true);
        e.update(3.0 * TAU + TAU / 4.0);
        assert_eq!(e.hardware_count(), 1500, "only motion after reconnection counts");
    }
}
