//! The proximity module's sensors: which datasheet curve each `sensorN` parameter value
//! selects. The curves themselves are in `r2p_drivers::rangers`, shared with the world model
//! that emulates the sensors.

pub use r2p_drivers::rangers::*;

/// The curve of sensor type `kind` (the `sensorN` parameter: 1, 2, 3); `None` for 0 (no
/// sensor) or an unknown type.
pub fn curve(kind: u32) -> Option<&'static Curve> {
    match kind {
        1 => Some(&GP2Y0A21YK),
        2 => Some(&GP2Y0A02YK),
        3 => Some(&MAXSONAR_LV_EZ_5V),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sensor_numbers_select_their_curves() {
        assert_eq!(curve(0), None);
        assert_eq!(curve(1), Some(&GP2Y0A21YK));
        assert_eq!(curve(2), Some(&GP2Y0A02YK));
        assert_eq!(curve(3), Some(&MAXSONAR_LV_EZ_5V));
        assert_eq!(curve(4), None);
    }
}
