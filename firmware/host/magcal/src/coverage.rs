//! How much of the field's circle (sphere) the samples of `r2p imu calibrate` cover: the field's
//! heading about the sensor's z axis in 36 sectors of 10° (a compass rose, shown while the user
//! turns the robot) and its elevation in 6 bands of 30° (for the full fit, which needs the
//! robot rolled and pitched too). A fit through samples on part of a circle extrapolates the
//! rest, so the command refuses to write one below [`MIN_SECTORS`] (and, full, [`MIN_BANDS`]).

/// Heading sectors.
pub const SECTORS: usize = 36;
/// Elevation bands.
pub const BANDS: usize = 6;
/// Fewest heading sectors a calibration is written with: three quarters of a turn. An ellipse
/// through a 270° arc is pinned down to well under a microtesla with the noise of a
/// magnetometer; through half a turn its far side is a guess.
pub const MIN_SECTORS: usize = 27;
/// Fewest elevation bands a full calibration is written with: four of six, i.e. the field seen
/// over 120° of elevation at least (turning the robot on the floor gives one band).
pub const MIN_BANDS: usize = 4;

/// Samples counted by heading sector and elevation band.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Coverage {
    /// Samples per 10° heading sector, from 0° (the sensor's +x) counter-clockwise.
    pub sectors: [u32; SECTORS],
    /// Samples per 30° elevation band, from −90° (the field along −z) up.
    pub bands: [u32; BANDS],
}

impl Default for Coverage {
    fn default() -> Self {
        Self::new()
    }
}

impl Coverage {
    /// Empty.
    pub fn new() -> Self {
        Self { sectors: [0; SECTORS], bands: [0; BANDS] }
    }

    /// Counts `v`, a field vector from the ellipsoid's centre (µT). A zero vector has no
    /// direction and is not counted.
    pub fn add(&mut self, v: [f64; 3]) {
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return;
        }
        let heading = v[1].atan2(v[0]).to_degrees().rem_euclid(360.0);
        // `min`: rem_euclid rounds a heading a hair below 0° up to exactly 360.
        self.sectors[((heading / 10.0) as usize).min(SECTORS - 1)] += 1;
        let elevation = (v[2] / norm).clamp(-1.0, 1.0).asin().to_degrees() + 90.0;
        self.bands[((elevation / 30.0) as usize).min(BANDS - 1)] += 1;
    }

    /// Heading sectors with at least one sample.
    pub fn sectors_covered(&self) -> usize {
        self.sectors.iter().filter(|&&n| n > 0).count()
    }

    /// Elevation bands with at least one sample.
    pub fn bands_covered(&self) -> usize {
        self.bands.iter().filter(|&&n| n > 0).count()
    }

    /// The compass rose as 36 characters, sector 0 first: `#` covered, `.` not.
    pub fn rose(&self) -> String {
        self.sectors.iter().map(|&n| if n > 0 { '#' } else { '.' }).collect()
    }

    /// The uncovered headings as ranges of degrees (`90–180°, 300–310°`), wrapping at 360°.
    pub fn missing(&self) -> String {
        let empty = |i: usize| self.sectors[i % SECTORS] == 0;
        if (0..SECTORS).all(empty) {
            return "0–360°".into();
        }
        // Start after a covered sector, so a gap across 0° is one range.
        let first = (0..SECTORS).find(|&i| !empty(i)).expect("one is covered");
        let mut ranges = Vec::new();
        let mut i = first;
        while i < first + SECTORS {
            if empty(i) {
                let start = i;
                while i < first + SECTORS && empty(i) {
                    i += 1;
                }
                ranges.push(format!("{}–{}°", (start % SECTORS) * 10, (i % SECTORS) * 10));
            } else {
                i += 1;
            }
        }
        ranges.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(deg: f64, elev: f64) -> [f64; 3] {
        let (h, e) = (deg.to_radians(), elev.to_radians());
        [40.0 * e.cos() * h.cos(), 40.0 * e.cos() * h.sin(), 40.0 * e.sin()]
    }

    #[test]
    fn headings_fall_in_their_ten_degree_sectors() {
        let mut c = Coverage::new();
        for deg in [0.0, 5.0, 9.99, 10.0, 359.9, -0.5, 185.0, 90.0] {
            c.add(at(deg, 0.0));
        }
        assert_eq!(c.sectors[0], 3);
        assert_eq!((c.sectors[1], c.sectors[35], c.sectors[18], c.sectors[9]), (1, 2, 1, 1));
        assert_eq!(c.sectors_covered(), 5);
        assert_eq!(c.sectors.iter().sum::<u32>(), 8);
        let rose = c.rose();
        assert_eq!(rose.len(), 36);
        assert_eq!(&rose[..3], "##.");
        assert_eq!(rose.chars().filter(|&ch| ch == '#').count(), 5);
        assert_eq!(rose.chars().nth(35), Some('#'));
    }

    #[test]
    fn a_heading_just_below_zero_is_in_the_last_sector() {
        // atan2 gives −1e-300 rad; rem_euclid(360) rounds −5.7e-299° up to exactly 360.0,
        // which would be sector 36 of 0…35.
        assert_eq!((-1e-300f64).to_degrees().rem_euclid(360.0), 360.0);
        let mut c = Coverage::new();
        c.add([40.0, -1e-300, 0.0]);
        assert_eq!((c.sectors[35], c.sectors_covered()), (1, 1));
    }

    #[test]
    fn elevations_fall_in_their_bands() {
        let mut c = Coverage::new();
        for elev in [-90.0, -89.0, -60.5, -59.5, -1.0, 0.0, 31.0, 89.0, 90.0] {
            c.add(at(45.0, elev));
        }
        assert_eq!(c.bands, [3, 1, 1, 1, 1, 2]);
        assert_eq!(c.bands_covered(), 6);
        let mut flat = Coverage::new();
        (0..360).for_each(|d| flat.add(at(d as f64, -60.0)));
        assert_eq!((flat.sectors_covered(), flat.bands_covered()), (36, 1));
    }

    #[test]
    fn a_zero_or_bad_vector_is_not_counted() {
        let mut c = Coverage::new();
        c.add([0.0; 3]);
        c.add([f64::NAN, 1.0, 0.0]);
        c.add([f64::INFINITY, 1.0, 0.0]);
        assert_eq!(c, Coverage::new());
        assert_eq!((c.sectors_covered(), c.bands_covered()), (0, 0));
    }

    #[test]
    fn the_missing_headings_are_ranges_that_wrap() {
        let mut c = Coverage::new();
        assert_eq!(c.missing(), "0–360°");
        (0..90).for_each(|d| c.add(at(d as f64 + 0.5, 0.0)));
        assert_eq!(c.missing(), "90–0°");
        (200..210).for_each(|d| c.add(at(d as f64 + 0.5, 0.0)));
        assert_eq!(c.missing(), "90–200°, 210–0°");
        let mut c = Coverage::new();
        (20..340).for_each(|d| c.add(at(d as f64 + 0.5, 0.0)));
        assert_eq!(c.missing(), "340–20°");
        (0..360).for_each(|d| c.add(at(d as f64, 0.0)));
        assert_eq!(c.missing(), "");
        assert_eq!(c.sectors_covered(), SECTORS);
    }
}
