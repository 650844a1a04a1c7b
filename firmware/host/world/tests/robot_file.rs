//! Robot files: the Triskar2 file loads as described, and broken files are refused with the
//! file, the key and what to do.

mod common;

use std::path::Path;

use r2p_world::boards::BoardKind;
use r2p_world::imu_module::ImuSensor;
use r2p_world::kinematics::Layout;
use r2p_world::magnetic::{EarthField, Iron};
use r2p_world::ranger::RangerKind;
use r2p_world::robot_file::Wiring;
use r2p_world::site::Site;
use r2p_world::{Robot, RobotError};

use common::triskar_path;

fn triskar_text() -> String {
    std::fs::read_to_string(triskar_path()).unwrap()
}

/// Parses `text` as `bad.toml` and returns the error.
fn refuse(text: &str) -> RobotError {
    match Robot::parse(text, "robots/bad.toml") {
        Ok(_) => panic!("accepted a broken file"),
        Err(e) => e,
    }
}

/// The Triskar2 file with `from` replaced by `to` (which must occur once).
fn edit(from: &str, to: &str) -> String {
    let t = triskar_text();
    assert_eq!(t.matches(from).count(), 1, "`{from}` must occur once");
    t.replace(from, to)
}

#[test]
fn triskar2_loads_as_the_paper_describes_it() {
    let r = Robot::load(triskar_path()).unwrap();
    assert_eq!(r.name, "triskar2");
    assert_eq!(r.bus.bit_rate, 1_000_000);
    assert_eq!(r.wheel_count(), 3);
    assert!(matches!(&r.base.layout, Layout::Omni { angles, .. } if angles.len() == 3));
    assert_eq!(r.base.footprint_radius_m * 2.0, 0.60);
    assert_eq!(r.base.params.mass_kg, 20.0);
    let kinds: Vec<BoardKind> = r.modules.iter().map(|m| m.kind()).collect();
    use BoardKind::*;
    assert_eq!(kinds, [Psu, Motor, Motor, Motor, Proximity, Gateway]);
    let prox = r.module("proximity").unwrap();
    let Wiring::Proximity { rangers } = &prox.wiring else { panic!() };
    assert_eq!(rangers.len(), 4);
    assert!(rangers.iter().all(|x| matches!(x.kind, RangerKind::Gp2y0a21 | RangerKind::Gp2y0a02)));
    assert_eq!(
        r.module("motor2").unwrap().wiring,
        Wiring::Motor { wheel: 1, encoder_inverted: false }
    );
    assert_eq!(r.module("psu").unwrap().uid.to_string(), "003A00253137510939383538");
    assert_eq!(r.battery.params.cells, 12);
    assert_eq!(r.obstacles.len(), 7);
}

#[test]
fn missing_key_names_file_line_key_and_fix() {
    let e = refuse(&edit("uid = \"0042002C3137510939383538\"\n", ""));
    assert_eq!(e.file, Path::new("robots/bad.toml"));
    assert_eq!(e.key, "modules[2].uid");
    assert_eq!(e.problem, "missing key");
    assert!(e.fix.contains("24 hex digits"), "{e}");
    let line = e.line.expect("line of the table");
    let text = edit("uid = \"0042002C3137510939383538\"\n", "");
    assert!(text.lines().nth(line - 1).unwrap().contains("[[modules]]"), "{e}");
    let shown = e.to_string();
    assert!(
        shown.starts_with(&format!("robots/bad.toml:{line}: modules[2].uid: missing key; add it")),
        "{shown}"
    );
}

#[test]
fn missing_top_level_key() {
    let e = refuse(&edit("seed = 2013\n", ""));
    assert_eq!(e.key, "robot.seed");
    assert!(e.fix.contains("same seed"), "{e}");
}

#[test]
fn unknown_module_kind_lists_the_kinds() {
    let e = refuse(&edit("kind = \"gateway\"", "kind = \"lidar\""));
    assert_eq!(e.key, "modules[5].kind");
    assert!(e.problem.contains("`lidar`"), "{e}");
    // The kinds are modules.toml's modules with an emulator model, in its order.
    assert!(e.fix.contains("\"psu\", \"motor\", \"imu\", \"proximity\", \"gateway\""), "{e}");
    assert!(e.fix.contains("modules.toml"), "{e}");
}

#[test]
fn misspelt_key_is_refused_not_ignored() {
    let e = refuse(&edit("wheel = 1", "whel = 1"));
    assert_eq!(e.key, "modules[2].whel");
    assert_eq!(e.problem, "unknown key");
    assert!(e.fix.contains("wheel"), "lists the expected keys: {e}");
}

#[test]
fn wrong_type_names_the_key() {
    let e = refuse(&edit("mass_kg = 20.0", "mass_kg = \"heavy\""));
    assert_eq!(e.key, "base.mass_kg");
    assert!(e.problem.contains("invalid type"), "{e}");
}

#[test]
fn semantic_errors() {
    let e = refuse(&edit("wheel = 2", "wheel = 3"));
    assert_eq!(e.key, "modules[3].wheel");
    assert!(e.problem.contains("0..2"), "{e}");

    let e = refuse(&edit("wheel = 2", "wheel = 1"));
    assert_eq!(e.key, "modules[3].wheel");
    assert!(e.problem.contains("already driven by modules[2]"), "{e}");

    let e =
        refuse(&edit("uid = \"0042002D3137510939383538\"", "uid = \"0042002C3137510939383538\""));
    assert_eq!(e.key, "modules[3].uid");
    assert!(e.problem.contains("already the uid of modules[2]"), "{e}");

    let e = refuse(&edit("uid = \"0042002D3137510939383538\"", "uid = \"0042002D31375109\""));
    assert_eq!(e.key, "modules[3].uid");
    assert!(e.fix.contains("24 hex digits"), "{e}");

    let e = refuse(&edit("battery = \"main\"", "battery = \"spare\""));
    assert_eq!(e.key, "modules[0].battery");
    assert!(e.fix.contains("\"main\""), "{e}");

    let e = refuse(&edit("sensor = \"gp2y0a02\"", "sensor = \"srf05\""));
    assert_eq!(e.key, "modules[4].rangers[0].sensor");
    assert!(e.fix.contains("\"maxsonar-lv-ez\""), "{e}");

    let e = refuse(&edit("channel = 3", "channel = 2"));
    assert_eq!(e.key, "modules[4].rangers[3].channel");

    let e = refuse(&edit("motor = \"maxon-re35-24v\"", "motor = \"re40\""));
    assert_eq!(e.key, "drive.motor");
    assert!(e.fix.contains("\"maxon-re35-24v\""), "{e}");

    let e = refuse(&edit("initial_soc = 1.0", "initial_soc = 1.5"));
    assert_eq!(e.key, "battery.initial_soc");

    let e = refuse(&edit(
        "wheel_angles_deg = [60.0, 180.0, 300.0]",
        "wheel_angles_deg = [0.0, 0.0, 180.0]",
    ));
    assert_eq!(e.key, "base.wheel_angles_deg");

    let e = refuse(&edit("radius_m = 0.1", "radius_m = 0.1\nmin = [0.0, 0.0]"));
    assert_eq!(e.key, "obstacles[6].min");
    assert!(e.problem.contains("does not apply to a circle"), "{e}");

    let e = refuse(&edit("wheel = 0\n", "wheel = 0\nbattery = \"main\"\n"));
    assert_eq!(e.key, "modules[1].battery");
    assert!(e.fix.contains("psu"), "{e}");
}

#[test]
fn wheel_without_motor_and_psu_count() {
    let mut t = triskar_text();
    let start = t.find("[[modules]]\nkind = \"motor\"\nname = \"motor3\"").unwrap();
    let end = start + t[start..].find("wheel = 2\n").unwrap() + "wheel = 2\n".len();
    t.replace_range(start..end, "");
    let e = refuse(&t);
    assert_eq!(e.key, "modules");
    assert!(e.problem.contains("wheel 2 has no motor module"), "{e}");
    assert!(e.fix.contains("kind = \"motor\" and wheel = 2"), "{e}");

    let t = edit("kind = \"psu\"\nname = \"psu\"\nuid = \"003A00253137510939383538\"\nbattery = \"main\"\nbus_load_a = 0.45",
        "kind = \"gateway\"\nname = \"psu\"\nuid = \"003A00253137510939383538\"");
    let e = refuse(&t);
    assert_eq!(e.key, "modules");
    assert!(e.problem.contains("0 psu modules") && e.fix.contains("exactly one psu"), "{e}");

    // A gateway does not take psu keys.
    let e = refuse(&edit("kind = \"psu\"", "kind = \"gateway\""));
    assert_eq!(e.key, "modules[0].battery");
}

#[test]
fn syntax_error_has_a_line() {
    let e = refuse(&edit("cycle_us = 10_000", "cycle_us = = 10"));
    let text = edit("cycle_us = 10_000", "cycle_us = = 10");
    let line = e.line.unwrap();
    assert!(text.lines().nth(line - 1).unwrap().contains("cycle_us"), "{e}");
    assert!(e.problem.starts_with("not valid TOML"), "{e}");
}

#[test]
fn missing_file_is_named() {
    let e = Robot::load("robots/nope.toml").unwrap_err();
    assert_eq!(e.file, Path::new("robots/nope.toml"));
    assert!(e.problem.contains("cannot read"), "{e}");
}

#[test]
fn differential_robot() {
    let r = common::diff();
    assert_eq!(r.wheel_count(), 2);
    assert!(matches!(r.base.layout, Layout::Differential { track, .. } if track == 0.3));
    assert_eq!(r.bus.bit_rate, 500_000);
    // An omni key on a differential base is refused.
    let t = common::DIFF_ROBOT.replace("track_m = 0.3", "track_m = 0.3\nwheel_distance_m = 0.2");
    let e = Robot::parse(&t, "diffbot.toml").unwrap_err();
    assert_eq!(e.key, "base.wheel_distance_m");
    assert!(e.problem.contains("does not apply to a differential base"), "{e}");
    // A third motor has no wheel to drive.
    let t = common::DIFF_ROBOT.replace("wheel = 1", "wheel = 2");
    let e = Robot::parse(&t, "diffbot.toml").unwrap_err();
    assert_eq!(e.key, "modules[2].wheel");
    assert!(e.problem.contains("the base has 2"), "{e}");
}

#[test]
fn an_imu_module_has_a_pose_and_only_it_does() {
    let imu = "\n[[modules]]\nkind = \"imu\"\nname = \"imu\"\nuid = \"0070001F3137510939383538\"\n";
    let r = Robot::parse(&(triskar_text() + imu), "a.toml").unwrap();
    let m = r.module("imu").unwrap();
    let plain = Wiring::Imu { mount: Default::default(), iron: Iron::NONE, unplugged: vec![] };
    assert_eq!((m.kind(), &m.wiring), (BoardKind::Imu, &plain));
    let posed = format!("{imu}pose = {{ x_m = -0.05, y_m = 0.02, theta_deg = 180.0 }}\n");
    let r = Robot::parse(&(triskar_text() + &posed), "a.toml").unwrap();
    let Wiring::Imu { mount, .. } = r.module("imu").unwrap().wiring else { panic!() };
    assert_eq!((mount.x, mount.y), (-0.05, 0.02));
    assert!((mount.theta.abs() - std::f64::consts::PI).abs() < 1e-12);
    let e = refuse(&edit("wheel = 1", "wheel = 1\npose = { x_m = 0.1 }"));
    assert_eq!(e.key, "modules[2].pose");
    assert!(e.fix.contains("imu modules"), "{e}");
}

#[test]
fn the_base_controller_runs_on_the_gateway_by_default_or_where_the_file_says() {
    use r2p_world::robot_file::BaseController;
    let r = Robot::load(triskar_path()).unwrap();
    let gateway = r.modules.iter().position(|m| m.name == "gateway").unwrap();
    assert_eq!(r.base_controller, Some(BaseController::Module(gateway)));
    let at = |v: &str| edit("kind = \"omni\"", &format!("kind = \"omni\"\ncontroller = \"{v}\""));
    let r = Robot::parse(&at("host"), "a.toml").unwrap();
    assert_eq!(r.base_controller, Some(BaseController::Host));
    let r = Robot::parse(&at("gateway"), "a.toml").unwrap();
    assert_eq!(r.base_controller, Some(BaseController::Module(gateway)));
    // An F103 module has no room for it; a name that is no module is a typo.
    let e = refuse(&at("proximity"));
    assert_eq!(e.key, "base.controller");
    assert!(e.problem.contains("only the gateway's image has room"), "{e}");
    assert_eq!(e.fix, "use \"gateway\" or \"host\"");
    let e = refuse(&at("gatway"));
    assert!(e.problem.contains("no module called `gatway`"), "{e}");
    // Without a gateway nothing runs it unless the file says so; a differential base has none.
    assert_eq!(common::diff().base_controller, None);
    let t = common::DIFF_ROBOT.replace("track_m = 0.3", "track_m = 0.3\ncontroller = \"host\"");
    let e = Robot::parse(&t, "diffbot.toml").unwrap_err();
    assert_eq!(e.key, "base.controller");
    assert!(e.problem.contains("three omni wheels"), "{e}");
}

/// The Triskar2 file with an IMU module carrying `keys`.
fn with_imu(keys: &str) -> String {
    triskar_text()
        + "\n[[modules]]\nkind = \"imu\"\nname = \"imu\"\nuid = \"0070001F3137510939383538\"\n"
        + keys
}

#[test]
fn an_imu_module_takes_the_robots_iron_and_sensors_unplugged_at_start() {
    let keys = "hard_iron_ut = [12.5, -8.0, 30.0]\n\
                soft_iron = [[1.1, 0.05, 0.0], [0.05, 0.9, 0.0], [0.0, 0.0, 1.0]]\n\
                unplugged = [\"gnss\", \"barometer\"]\n";
    let r = Robot::parse(&with_imu(keys), "a.toml").unwrap();
    let Wiring::Imu { iron, unplugged, .. } = &r.module("imu").unwrap().wiring else { panic!() };
    assert_eq!(iron.hard_ut, [12.5, -8.0, 30.0]);
    assert_eq!(iron.soft, [[1.1, 0.05, 0.0], [0.05, 0.9, 0.0], [0.0, 0.0, 1.0]]);
    assert_eq!(unplugged, &[ImuSensor::Gnss, ImuSensor::Barometer]);
    // Each refused with its key and what to do.
    let e = Robot::parse(&with_imu("unplugged = [\"gps\"]\n"), "a.toml").unwrap_err();
    assert_eq!(e.key, "modules[6].unplugged[0]");
    assert!(e.problem.contains("unknown sensor `gps`"), "{e}");
    assert!(e.fix.contains("\"accel_gyro\", \"magnetometer\", \"barometer\", \"gnss\""), "{e}");
    let e = Robot::parse(&with_imu("unplugged = [\"gnss\", \"gnss\"]\n"), "a.toml").unwrap_err();
    assert_eq!(e.key, "modules[6].unplugged[1]");
    assert!(e.problem.contains("listed twice"), "{e}");
    let e = Robot::parse(&with_imu("hard_iron_ut = [0.0, 2000.0, 0.0]\n"), "a.toml").unwrap_err();
    assert_eq!(e.key, "modules[6].hard_iron_ut");
    assert!(e.problem.contains("-1600..=1600"), "{e}");
    let e = Robot::parse(&with_imu("hard_iron_ut = [0.0, 1.0]\n"), "a.toml").unwrap_err();
    assert_eq!(e.key, "modules[6].hard_iron_ut");
    let mirror = "soft_iron = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]\n";
    let e = Robot::parse(&with_imu(mirror), "a.toml").unwrap_err();
    assert_eq!(e.key, "modules[6].soft_iron");
    assert!(e.problem.contains("determinant -1.000"), "{e}");
    assert!(e.fix.contains("near the identity"), "{e}");
    // Down to a determinant of 0.01 exactly (0.5 · 0.02 · 1: a field squeezed to a hundredth
    // in the plane), not below.
    let flat = "soft_iron = [[0.5, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 1.0]]\n";
    assert!(Robot::parse(&with_imu(flat), "a.toml").is_ok());
    let flatter = "soft_iron = [[0.5, 0.0, 0.0], [0.0, 0.018, 0.0], [0.0, 0.0, 1.0]]\n";
    let e = Robot::parse(&with_imu(flatter), "a.toml").unwrap_err();
    assert!(e.problem.contains("determinant 0.009"), "{e}");
    let huge = "soft_iron = [[11.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]\n";
    let e = Robot::parse(&with_imu(huge), "a.toml").unwrap_err();
    assert_eq!(e.key, "modules[6].soft_iron");
    assert!(e.problem.contains("-10..=10"), "{e}");
    // On another kind of module they belong to imu modules.
    let e = refuse(&edit("wheel = 1", "wheel = 1\nunplugged = [\"gnss\"]"));
    assert_eq!(e.key, "modules[2].unplugged");
    assert!(e.fix.contains("imu modules"), "{e}");
    let e = refuse(&edit("wheel = 1", "wheel = 1\nhard_iron_ut = [1.0, 2.0, 3.0]"));
    assert_eq!(e.key, "modules[2].hard_iron_ut");
}

#[test]
fn the_site_defaults_to_milan_and_each_key_is_checked() {
    assert_eq!(Robot::load(triskar_path()).unwrap().site, Site::MILAN);
    let site = "\n[site]\nlatitude_deg = -33.87\nlongitude_deg = 151.21\naltitude_m = 40.0\n\
                geoid_separation_m = 22.5\nfield_intensity_ut = 57.3\n\
                field_inclination_deg = -64.3\nfield_declination_deg = 12.8\n\
                sea_level_pressure_pa = 100900.0\n";
    let r = Robot::parse(&(triskar_text() + site), "a.toml").unwrap();
    let want = Site {
        latitude_deg: -33.87,
        longitude_deg: 151.21,
        altitude_m: 40.0,
        geoid_separation_m: 22.5,
        field: EarthField { intensity_ut: 57.3, inclination_deg: -64.3, declination_deg: 12.8 },
        sea_level_pa: 100_900.0,
    };
    assert_eq!(r.site, want);
    // A key left out takes Milan's value.
    let r = Robot::parse(&(triskar_text() + "\n[site]\naltitude_m = 300.0\n"), "a.toml").unwrap();
    assert_eq!(r.site, Site { altitude_m: 300.0, ..Site::MILAN });
    for (key, bad, need) in [
        ("latitude_deg", "89.5", "-89..=89"),
        ("longitude_deg", "-181.0", "-180..=180"),
        ("altitude_m", "12000.0", "-500..=9000"),
        ("geoid_separation_m", "-120.0", "-110..=90"),
        ("field_intensity_ut", "0.0", "1..=100"),
        ("field_inclination_deg", "91.0", "-90..=90"),
        ("field_declination_deg", "200.0", "-180..=180"),
        ("sea_level_pressure_pa", "1013.25", "87000..=108500"),
        ("altitude_m", "nan", "-500..=9000"),
    ] {
        let text = triskar_text() + &format!("\n[site]\n{key} = {bad}\n");
        let e = Robot::parse(&text, "robots/bad.toml").unwrap_err();
        assert_eq!(e.key, format!("site.{key}"), "{e}");
        assert!(e.problem.contains(need), "{e}");
        assert_eq!(e.file, Path::new("robots/bad.toml"));
    }
    let e = Robot::parse(&(triskar_text() + "\n[site]\nlatitude = 45.0\n"), "a.toml").unwrap_err();
    assert_eq!((e.key.as_str(), e.problem.as_str()), ("site.latitude", "unknown key"));
    assert!(e.fix.contains("latitude_deg"), "{e}");
    let e = Robot::parse(&(triskar_text() + "\n[site]\naltitude_m = \"high\"\n"), "a.toml")
        .unwrap_err();
    assert_eq!(e.key, "site.altitude_m");
    assert!(e.problem.contains("invalid type"), "{e}");
}
