//! The board file's data model, loaded and checked.

use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};

use serde::Deserialize;

/// How the firmware configures a pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Digital input.
    Input,
    /// Push-pull output.
    Output,
    /// ADC input.
    Analog,
    /// Alternate function of a peripheral (`function` names it).
    Alternate,
    /// SWD: wired, never touched by the application.
    Debug,
    /// HSE crystal.
    Oscillator,
    /// A strap (e.g. BOOT1): wired, never touched.
    Reserved,
}

/// Internal pull of an input.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Pull {
    /// Floating.
    #[default]
    None,
    /// Pull-up.
    Up,
    /// Pull-down.
    Down,
}

/// Which level means "on".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Active {
    /// High is on.
    #[default]
    High,
    /// Low is on.
    Low,
}

/// Initial level of an output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    /// High.
    High,
    /// Low.
    Low,
}

/// One pin's entry.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pin {
    /// Net name in the schematic, and the firmware's name for the pin.
    pub signal: String,
    /// How the firmware configures it.
    pub mode: Mode,
    /// Peripheral signal (`analog` and `alternate`), e.g. `TIM1_CH1N`.
    pub function: Option<String>,
    /// Boot level of an output.
    pub init: Option<Level>,
    /// Pull of an input.
    #[serde(default)]
    pub pull: Pull,
    /// Which level means "on".
    #[serde(default)]
    pub active: Active,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHeader {
    module: Option<String>,
    revision: Option<String>,
    extends: Option<String>,
    schematic: Option<String>,
    mcu: Option<String>,
    package: Option<String>,
    hse_hz: Option<u32>,
    sysclk_hz: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    board: RawHeader,
    #[serde(default)]
    afio: BTreeMap<String, u32>,
    #[serde(default)]
    pins: BTreeMap<String, Pin>,
}

/// A board file merged with its base.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Board {
    /// Module name.
    pub module: String,
    /// Hardware revision.
    pub revision: String,
    /// Exact MCU part.
    pub mcu: String,
    /// MCU package.
    pub package: String,
    /// Crystal frequency.
    pub hse_hz: u32,
    /// Core clock.
    pub sysclk_hz: u32,
    /// Schematic the pin checker reads (repository-relative).
    pub schematic: Option<String>,
    /// AFIO remap fields (STM32F1).
    pub afio: BTreeMap<String, u32>,
    /// Pins by name (`PA0`), sorted.
    pub pins: BTreeMap<String, Pin>,
    /// The files read, module file last.
    pub files: Vec<PathBuf>,
}

/// A board file that cannot be used: which file, which key, what to do.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BoardError {
    /// The file at fault.
    pub file: PathBuf,
    /// What is wrong and what to do.
    pub message: String,
}

impl fmt::Display for BoardError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.file.display(), self.message)
    }
}

impl std::error::Error for BoardError {}

fn err(file: &Path, message: impl Into<String>) -> BoardError {
    BoardError { file: file.to_path_buf(), message: message.into() }
}

fn is_pin_name(name: &str) -> bool {
    let b = name.as_bytes();
    b.len() >= 3
        && b[0] == b'P'
        && (b'A'..=b'K').contains(&b[1])
        && name[2..].parse::<u8>().is_ok_and(|n| n <= 15)
}

fn is_signal_name(s: &str) -> bool {
    s.starts_with(|c: char| c.is_ascii_uppercase())
        && s.chars().all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_')
}

impl Board {
    /// Loads `path` and its `extends` chain, and checks every entry.
    pub fn load(path: &Path) -> Result<Self, BoardError> {
        let mut chain = Vec::new();
        let mut next = Some(path.to_path_buf());
        while let Some(file) = next.take() {
            if chain.iter().any(|(f, _): &(PathBuf, RawFile)| f == &file) {
                return Err(err(&file, "`extends` forms a cycle"));
            }
            let text = std::fs::read_to_string(&file)
                .map_err(|e| err(&file, format!("cannot read: {e}")))?;
            let raw: RawFile = toml::from_str(&text).map_err(|e| err(&file, e.to_string()))?;
            next = raw.board.extends.as_ref().map(|b| file.with_file_name(b));
            chain.push((file, raw));
        }
        chain.reverse(); // base first
        let files: Vec<PathBuf> = chain.iter().map(|(f, _)| f.clone()).collect();
        let mut header: BTreeMap<&str, (String, &Path)> = BTreeMap::new();
        let mut nums: BTreeMap<&str, u32> = BTreeMap::new();
        let mut afio = BTreeMap::new();
        let mut pins: BTreeMap<String, Pin> = BTreeMap::new();
        let mut owner: BTreeMap<String, PathBuf> = BTreeMap::new();
        for (file, raw) in &chain {
            let h = &raw.board;
            for (key, v) in [
                ("module", &h.module),
                ("revision", &h.revision),
                ("schematic", &h.schematic),
                ("mcu", &h.mcu),
                ("package", &h.package),
            ] {
                if let Some(v) = v {
                    header.insert(key, (v.clone(), file));
                }
            }
            for (key, v) in [("hse_hz", h.hse_hz), ("sysclk_hz", h.sysclk_hz)] {
                if let Some(v) = v {
                    nums.insert(key, v);
                }
            }
            afio.extend(raw.afio.iter().map(|(k, v)| (k.clone(), *v)));
            for (name, pin) in &raw.pins {
                Self::check_pin(file, name, pin)?;
                if let Some(first) = owner.get(name) {
                    return Err(err(
                        file,
                        format!(
                            "pin {name} is already defined in {}: define it once",
                            first.display()
                        ),
                    ));
                }
                if let Some((other, _)) = pins.iter().find(|(_, p)| p.signal == pin.signal) {
                    return Err(err(
                        file,
                        format!(
                            "signal {} is on {other} and {name}: a signal has one pin",
                            pin.signal
                        ),
                    ));
                }
                owner.insert(name.clone(), file.clone());
                pins.insert(name.clone(), pin.clone());
            }
        }
        let module_file = files.last().expect("at least one file").clone();
        let need = |key: &str| {
            header.get(key).map(|(v, _)| v.clone()).ok_or_else(|| {
                err(&module_file, format!("[board] has no `{key}` (nor has its base): add it"))
            })
        };
        let need_num = |key: &str| {
            nums.get(key).copied().ok_or_else(|| {
                err(&module_file, format!("[board] has no `{key}` (nor has its base): add it"))
            })
        };
        Ok(Board {
            module: need("module")?,
            revision: need("revision")?,
            mcu: need("mcu")?,
            package: need("package")?,
            hse_hz: need_num("hse_hz")?,
            sysclk_hz: need_num("sysclk_hz")?,
            schematic: header.get("schematic").map(|(v, _)| v.clone()),
            afio,
            pins,
            files,
        })
    }

    fn check_pin(file: &Path, name: &str, pin: &Pin) -> Result<(), BoardError> {
        let at = |what: String| err(file, format!("pins.{name}: {what}"));
        if !is_pin_name(name) {
            return Err(at("not a pin name: use the port and number, e.g. PA0 or PC13".into()));
        }
        if !is_signal_name(&pin.signal) {
            return Err(at(format!(
                "signal {:?} must be an upper-case net name (A-Z, 0-9, _), as in the schematic",
                pin.signal
            )));
        }
        let needs_function = matches!(pin.mode, Mode::Analog | Mode::Alternate);
        match (&pin.function, needs_function) {
            (None, true) => {
                return Err(at(format!("mode {:?} needs `function`, e.g. ADC1_IN0", pin.mode)))
            }
            (Some(f), false) => {
                return Err(at(format!(
                    "`function = {f:?}` only applies to analog or alternate pins"
                )))
            }
            (Some(f), true) if !f.contains('_') => {
                return Err(at(format!("function {f:?} must be PERIPHERAL_SIGNAL, e.g. TIM1_CH1")))
            }
            _ => {}
        }
        if pin.init.is_some() != (pin.mode == Mode::Output) {
            return Err(at(if pin.mode == Mode::Output {
                "an output needs `init = \"high\"` or `\"low\"` (its level at boot)".into()
            } else {
                "`init` only applies to outputs".into()
            }));
        }
        if pin.pull != Pull::None && pin.mode != Mode::Input {
            return Err(at("`pull` only applies to inputs".into()));
        }
        Ok(())
    }
}
