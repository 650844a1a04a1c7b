//! Which of a board's MCU signals the world drives or reads, by the signal names of the HAL
//! board files (`firmware/boards/*.toml`), so that an emulated board can wire its peripherals
//! to its slice of the world generically: an ADC channel reads the world's analog signal of
//! the same name, a PWM output drives the world's H-bridge leg of that name, and so on.
//!
//! Levels are electrical, as at the pin: `true` = high. An active-low input such as
//! `DRV_FAULT` reads `false` while its fault is present.

/// A module the emulator runs, as modules.toml lists it: a robot file's `kind` is its `name`,
/// and its `emulator` entry names the [`BoardKind`] that models it. The table
/// ([`MODULE_KINDS`]) is generated from modules.toml by build.rs, so a module that
/// `scripts/new-module` adds (`emulator = "template"`) is a kind at once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModuleKind {
    /// The module's name in modules.toml, and the robot file's `kind`.
    pub name: &'static str,
    /// Its `emulator` entry: the name of the model that runs it.
    pub emulator: &'static str,
    /// The line of modules.toml with that entry, for error messages.
    pub line: u32,
}

include!(concat!(env!("OUT_DIR"), "/module_kinds.rs"));

impl ModuleKind {
    /// The module of modules.toml called `name`, if the emulator runs it.
    pub fn named(name: &str) -> Option<&'static ModuleKind> {
        MODULE_KINDS.iter().find(|k| k.name == name)
    }

    /// The model that runs this module; an `emulator` entry that names no model is an error
    /// naming the manifest's line and the models there are.
    pub fn model(&self) -> Result<BoardKind, String> {
        BoardKind::from_name(self.emulator).ok_or_else(|| {
            let models: Vec<_> =
                BoardKind::ALL.iter().map(|k| format!("\"{}\"", k.name())).collect();
            format!(
                "modules.toml:{}: module `{}`: the emulator has no model `{}`; use one of {} \
                 (\"template\" until the module has its own, docs/adding-a-module.md)",
                self.line,
                self.name,
                self.emulator,
                models.join(", ")
            )
        })
    }
}

/// An emulator model: the code that wires a kind of board to the world (its signals here, its
/// `Wiring` in a robot file, its boot function in firmware/host/emu). Modules name the model
/// that runs them in modules.toml ([`ModuleKind`]); several may share one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum BoardKind {
    /// Power supply: battery to 5 V bus, sync master.
    Psu,
    /// DC motor controller.
    Motor,
    /// Up to four range sensors.
    Proximity,
    /// Ethernet gateway (no simulated peripherals).
    Gateway,
    /// IMU: an LSM6DSO on SPI, reading the base's motion (no pin-level signals: the
    /// emulator's SPI and LSM6DSO models sit between the firmware and [`crate::imu`]).
    Imu,
    /// The module template (firmware/apps/template: heartbeat, one topic), and the stub model of
    /// a module `scripts/new-module` scaffolds until it gets its own: nothing in the world.
    Template,
}

/// How the world sees a signal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKind {
    /// An analog input: the firmware reads ADC counts ([`crate::World::read_adc`]).
    Analog,
    /// A timer counting a quadrature encoder ([`crate::World::read_counter`]).
    Counter,
    /// A PWM output, the duty of one H-bridge leg ([`crate::World::set_pwm`]).
    Pwm,
    /// A digital output the firmware drives ([`crate::World::set_output`]).
    Output,
    /// A digital input the firmware reads ([`crate::World::read_input`]).
    Input,
}

impl SignalKind {
    /// How error messages name this kind.
    pub fn describe(self) -> &'static str {
        match self {
            SignalKind::Analog => "analog input",
            SignalKind::Counter => "encoder counter",
            SignalKind::Pwm => "PWM output",
            SignalKind::Output => "digital output",
            SignalKind::Input => "digital input",
        }
    }
}

/// One signal of a board that the world models.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SignalSpec {
    /// Signal (net) name, as in the board file.
    pub name: &'static str,
    /// What it is to the world.
    pub kind: SignalKind,
    /// For an output, its reset level (the board file's `init`).
    pub init: Option<bool>,
}

const fn sig(name: &'static str, kind: SignalKind) -> SignalSpec {
    SignalSpec { name, kind, init: None }
}

const fn out(name: &'static str, init: bool) -> SignalSpec {
    SignalSpec { name, kind: SignalKind::Output, init: Some(init) }
}

/// PSU: battery voltage, battery current, bus voltage; bus switch and its fault flag.
pub const PSU_SIGNALS: &[SignalSpec] = &[
    sig("VIN_SENSE", SignalKind::Analog),
    sig("IIN_SENSE", SignalKind::Analog),
    sig("VOUT_SENSE", SignalKind::Analog),
    out("BUS_EN", true),
    sig("BUS_FAULT", SignalKind::Input),
];

/// Motor controller: motor current and supply, encoder, H-bridge legs A and B (their high
/// sides; the complementary low sides follow), driver enable and fault.
pub const MOTOR_SIGNALS: &[SignalSpec] = &[
    sig("MOTOR_CURRENT", SignalKind::Analog),
    sig("VMOT_SENSE", SignalKind::Analog),
    sig("ENC_A", SignalKind::Counter),
    sig("PWM_AH", SignalKind::Pwm),
    sig("PWM_BH", SignalKind::Pwm),
    out("DRV_EN", false),
    sig("DRV_FAULT", SignalKind::Input),
];

/// Proximity: four sensor channels, the sensors' 5 V switch and its fault flag.
pub const PROXIMITY_SIGNALS: &[SignalSpec] = &[
    sig("PROX_CH0", SignalKind::Analog),
    sig("PROX_CH1", SignalKind::Analog),
    sig("PROX_CH2", SignalKind::Analog),
    sig("PROX_CH3", SignalKind::Analog),
    out("SENSOR_PWR_EN", true),
    sig("SENSOR_PWR_FAULT", SignalKind::Input),
];

impl BoardKind {
    /// Every model.
    pub const ALL: [BoardKind; 6] = [
        BoardKind::Psu,
        BoardKind::Motor,
        BoardKind::Proximity,
        BoardKind::Gateway,
        BoardKind::Imu,
        BoardKind::Template,
    ];

    /// The name the robot file uses.
    pub fn name(self) -> &'static str {
        match self {
            BoardKind::Psu => "psu",
            BoardKind::Motor => "motor",
            BoardKind::Proximity => "proximity",
            BoardKind::Gateway => "gateway",
            BoardKind::Imu => "imu",
            BoardKind::Template => "template",
        }
    }

    /// The kind called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The signals the world models for this kind.
    pub fn signals(self) -> &'static [SignalSpec] {
        match self {
            BoardKind::Psu => PSU_SIGNALS,
            BoardKind::Motor => MOTOR_SIGNALS,
            BoardKind::Proximity => PROXIMITY_SIGNALS,
            BoardKind::Gateway | BoardKind::Imu | BoardKind::Template => &[],
        }
    }

    /// Index of signal `name` of kind `kind` in [`Self::signals`].
    pub fn signal_index(self, name: &str, kind: SignalKind) -> Option<usize> {
        self.signals().iter().position(|s| s.name == name && s.kind == kind)
    }

    /// Names of this kind's signals of kind `kind`.
    pub fn signal_names(self, kind: SignalKind) -> Vec<&'static str> {
        self.signals().iter().filter(|s| s.kind == kind).map(|s| s.name).collect()
    }

    /// Its HAL board file under `firmware/boards/`.
    pub fn board_file(self) -> Option<&'static str> {
        match self {
            BoardKind::Psu => Some("psu.toml"),
            BoardKind::Motor => Some("motor.toml"),
            BoardKind::Proximity => Some("proximity.toml"),
            BoardKind::Imu => Some("imu.toml"),
            BoardKind::Template => Some("template.toml"),
            BoardKind::Gateway => Some("gateway.toml"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// The `[pins]` table of a board file as (signal, mode, function, init) rows.
    fn pins(file: &str) -> Vec<(String, String, String, String)> {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../boards").join(file);
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        let doc: toml::Table = toml::from_str(&text).unwrap();
        let s =
            |v: &toml::Value, k: &str| v.get(k).and_then(|x| x.as_str()).unwrap_or("").to_string();
        doc["pins"]
            .as_table()
            .unwrap()
            .values()
            .map(|p| (s(p, "signal"), s(p, "mode"), s(p, "function"), s(p, "init")))
            .collect()
    }

    #[test]
    fn signals_match_the_hal_board_files() {
        for kind in BoardKind::ALL {
            let Some(file) = kind.board_file() else { continue };
            let pins = pins(file);
            for s in kind.signals() {
                let (_, mode, function, init) = pins
                    .iter()
                    .find(|p| p.0 == s.name)
                    .unwrap_or_else(|| panic!("{file}: no pin with signal {}", s.name));
                let ok = match s.kind {
                    SignalKind::Analog => mode == "analog",
                    SignalKind::Counter => mode == "alternate" && function.ends_with("_CH1"),
                    SignalKind::Pwm => mode == "alternate" && function.starts_with("TIM"),
                    SignalKind::Output => mode == "output",
                    SignalKind::Input => {
                        mode == "input" || (mode == "alternate" && function.ends_with("BKIN"))
                    }
                };
                assert!(ok, "{file}: {} is {mode} {function}, world expects {:?}", s.name, s.kind);
                if let Some(level) = s.init {
                    assert_eq!(init, if level { "high" } else { "low" }, "{file}: {} init", s.name);
                }
            }
            // Every analog pin of the board is fed by the world.
            for (signal, mode, ..) in &pins {
                if mode == "analog" {
                    assert!(
                        kind.signal_index(signal, SignalKind::Analog).is_some(),
                        "{file}: analog pin {signal} has no world signal"
                    );
                }
            }
        }
    }

    #[test]
    fn names_round_trip() {
        for k in BoardKind::ALL {
            assert_eq!(BoardKind::from_name(k.name()), Some(k));
        }
        assert_eq!(BoardKind::from_name("lidar"), None);
        assert_eq!(BoardKind::Motor.signal_names(SignalKind::Pwm), ["PWM_AH", "PWM_BH"]);
    }
}
