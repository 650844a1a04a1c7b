//! The magnetometer's hard- and soft-iron calibration, as the module applies it.
//!
//! A magnetometer fixed to a robot measures `m = A·b + h` (b the Earth's field in the sensor's
//! frame): the robot's ferrous parts bend and scale the field (soft iron, A) and its magnets,
//! magnetised steel and the sensor's own zero offset add a constant (hard iron, h). Rotated
//! through every orientation, m traces an ellipsoid centred on h instead of a sphere.
//! `r2p imu calibrate` records the raw field while the user turns the robot, fits that
//! ellipsoid on the host (the fit needs an eigen-decomposition: no place for it in the F103's
//! flash) and writes the parameters `mag_offset_*` = h and `mag_soft_*` = S ≈ A⁻¹ (symmetric:
//! the fit cannot tell a rotation of the sphere from none, and a symmetric S keeps the
//! sensor's axes). The module then uses `S·(m − h)`, the field on a sphere, for its heading.

/// Hard-iron offset and soft-iron matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MagCal {
    /// h, µT.
    pub offset: [f32; 3],
    /// S, rows.
    pub soft: [[f32; 3]; 3],
}

impl MagCal {
    /// No correction.
    pub const IDENTITY: MagCal =
        MagCal { offset: [0.0; 3], soft: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] };

    /// The calibrated field `S·(m − h)`, µT.
    pub fn apply(&self, m: [f32; 3]) -> [f32; 3] {
        let d: [f32; 3] = core::array::from_fn(|i| m[i] - self.offset[i]);
        self.soft.map(|row| row[0] * d[0] + row[1] * d[1] + row[2] * d[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_offset_comes_off_before_the_matrix() {
        let cal = MagCal {
            offset: [10.0, -5.0, 2.0],
            soft: [[2.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 0.5]],
        };
        // m − h = (1, 1, 4): S·(1, 1, 4) = (2.5, 1.5, 2).
        assert_eq!(cal.apply([11.0, -4.0, 6.0]), [2.5, 1.5, 2.0]);
        assert_eq!(MagCal::IDENTITY.apply([1.0, 2.0, 3.0]), [1.0, 2.0, 3.0]);
    }
}
