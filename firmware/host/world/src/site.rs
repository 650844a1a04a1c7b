//! Where on Earth the robot's world is (issue 21): the geodetic place of the world's origin
//! (0, 0, 0), and what the IMU module's magnetometer, barometer and GNSS receiver find there:
//! the Earth's field and the day's sea-level pressure. A robot file's `[site]` table gives
//! them (robots/README.md); [`Site::MILAN`] is the default.
//!
//! **Heights.** A user knows the site's altitude above mean sea level (a map's contour, an
//! airfield's elevation): the barometer's atmosphere is reckoned from it ([`crate::pressure`]).
//! A GNSS receiver works on the WGS-84 ellipsoid: the origin's ellipsoidal height is the
//! altitude plus the geoid's separation N there (EGM96 gives N; around Milan it is ≈ 47 m,
//! NOT VERIFIED: the same figure `periph::ubx_gnss` uses to report heights above sea level).
//!
//! **The Earth's field** at the site as the three elements a geomagnetic model gives
//! ([`EarthField`]: NOAA's World Magnetic Model calculator, for the site and the date). It is
//! uniform over a robot's few metres: local anomalies (steel in the floor, rebar) are not
//! modelled.
//!
//! **Sea-level pressure** is the day's weather: the QNH a weather report gives, the pressure
//! the ISA would need at sea level to put the site's pressure at its altitude.

use crate::gnss::Geodetic;
use crate::magnetic::EarthField;
use crate::pressure::P0_PA;

/// A robot's site.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Site {
    /// Latitude of the world's origin, degrees north.
    pub latitude_deg: f64,
    /// Longitude of the world's origin, degrees east.
    pub longitude_deg: f64,
    /// Altitude of the world's floor above mean sea level, m.
    pub altitude_m: f64,
    /// The geoid's height above the WGS-84 ellipsoid there (N), m.
    pub geoid_separation_m: f64,
    /// The Earth's field there.
    pub field: EarthField,
    /// Sea-level pressure of the day (QNH), Pa.
    pub sea_level_pa: f64,
}

impl Site {
    /// Politecnico di Milano's Leonardo campus, where R2P and the Triskar2 were built:
    /// 45.478° N, 9.227° E, 122 m above sea level (map figures, approximate), N ≈ 47 m (NOT
    /// VERIFIED), the field of [`EarthField::MILAN`], the standard atmosphere's 101 325 Pa.
    pub const MILAN: Site = Site {
        latitude_deg: 45.478,
        longitude_deg: 9.227,
        altitude_m: 122.0,
        geoid_separation_m: 47.0,
        field: EarthField::MILAN,
        sea_level_pa: P0_PA,
    };

    /// The world's origin on the ellipsoid: what a GNSS receiver at (0, 0, 0) reads without
    /// error.
    pub fn origin(&self) -> Geodetic {
        Geodetic {
            lat_deg: self.latitude_deg,
            lon_deg: self.longitude_deg,
            height_m: self.altitude_m + self.geoid_separation_m,
        }
    }
}

impl Default for Site {
    fn default() -> Self {
        Self::MILAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_origin_is_the_site_on_the_ellipsoid() {
        let s = Site { altitude_m: 100.0, geoid_separation_m: -30.0, ..Site::MILAN };
        assert_eq!(s.origin(), Geodetic { lat_deg: 45.478, lon_deg: 9.227, height_m: 70.0 });
        assert_eq!(Site::default(), Site::MILAN);
        assert_eq!(Site::MILAN.origin().height_m, 169.0);
    }
}
