//! `r2p flash MODULE`: writes a module's committed image (`firmware/images/<module>.elf`)
//! through an SWD probe with probe-rs, then resets the module so that the image runs.
//!
//! The module, its chip and its image come from the module manifest (`modules.toml`, the one
//! list of modules); the chip's name there is probe-rs's name for it (tests/test_probe_targets.py
//! checks every image against probe-rs's description of that chip). probe-rs is not built by
//! `scripts/setup` (it takes ~15 min on 2 cores): it is found in `.tools/probe-rs` (where
//! `make probe-rs` installs the pinned version) or on `PATH`, and when it is missing the error
//! gives the exact command that installs it.

use std::ffi::{OsStr, OsString};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use clap::Args;

use crate::args::emit;
use crate::error::CliError;

/// The probe-rs release the project uses: the same version as the `probe-rs` crate pinned in
/// [`PROBE_RS_PIN`] for its target descriptions (a test checks that they agree).
pub const PROBE_RS_VERSION: &str = "0.32.0";
/// Where the pinned `probe-rs` crate is named, relative to the repository.
pub const PROBE_RS_PIN: &str = "firmware/tools/probe-rs/Cargo.toml";
/// Where `make probe-rs` installs probe-rs, relative to the repository (looked at before `PATH`).
pub const PROBE_RS_LOCAL: &str = ".tools/probe-rs/bin/probe-rs";
/// The guide for wiring a probe and recovering a board.
pub const GUIDE: &str = "docs/flashing.md";

/// `r2p flash` options.
#[derive(Args, Debug, Clone)]
pub struct FlashArgs {
    /// The module whose committed image to write (a name from modules.toml, e.g. psu, motor)
    pub module: String,
    /// Which probe, when more than one is attached: VID:PID or VID:PID:SERIAL as `probe-rs
    /// list` shows them
    #[arg(long, value_name = "VID:PID[:SERIAL]")]
    pub probe: Option<String>,
    /// Hold the chip in reset while attaching (when the running firmware keeps the probe out:
    /// SWD pins reused, deep sleep; needs the probe's NRST wired)
    #[arg(long)]
    pub connect_under_reset: bool,
    /// Print the probe-rs commands instead of running them
    #[arg(long)]
    pub dry_run: bool,
    /// The probe-rs executable to use (default: .tools/probe-rs/bin/probe-rs, then PATH)
    #[arg(long, value_name = "FILE")]
    pub probe_rs: Option<PathBuf>,
    /// The R2P repository (default: the one around the current folder, or around r2p itself)
    #[arg(long, value_name = "DIR")]
    pub root: Option<PathBuf>,
}

/// What to write where: a module's committed image and the chip it is built for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FlashTarget {
    /// The module's name.
    pub module: String,
    /// probe-rs's name of its chip (modules.toml's `image.mcu`).
    pub chip: String,
    /// Its image, relative to the repository (`firmware/images/<module>.elf`).
    pub image: PathBuf,
    /// The bootloader written first, for an image behind one (modules.toml's `slot = "active"`):
    /// its MCU's bootloader image from firmware/images.toml.
    pub bootloader: Option<PathBuf>,
}

/// The repository around `start`: the nearest folder holding `modules.toml` and
/// `firmware/images.toml`.
pub fn find_root(start: &Path) -> Option<PathBuf> {
    start
        .ancestors()
        .find(|d| d.join("modules.toml").is_file() && d.join("firmware/images.toml").is_file())
        .map(Path::to_path_buf)
}

/// The module `module`'s image and chip, from `root`'s modules.toml.
pub fn flash_target(root: &Path, module: &str) -> Result<FlashTarget, CliError> {
    let path = root.join("modules.toml");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
    let manifest: toml::Table = toml::from_str(&text).map_err(|e| {
        CliError::new(format!(
            "{}: {e} (scripts/py -m r2ptools.manifest checks it)",
            path.display()
        ))
    })?;
    let modules = manifest.get("module").and_then(|m| m.as_array()).map_or(&[][..], |v| v);
    let name_of = |m: &toml::Value| m.get("name").and_then(|n| n.as_str()).map(str::to_string);
    let with_image: Vec<String> =
        modules.iter().filter(|m| m.get("image").is_some()).filter_map(name_of).collect();
    let Some(entry) = modules.iter().find(|m| name_of(m).as_deref() == Some(module)) else {
        return Err(CliError::new(format!(
            "no module named {module:?} in modules.toml; modules with an image: {}",
            with_image.join(", ")
        )));
    };
    let Some(chip) = entry.get("image").and_then(|i| i.get("mcu")).and_then(|c| c.as_str()) else {
        return Err(CliError::new(format!(
            "module {module} has no firmware image yet (its modules.toml entry has no `image`); \
             modules with an image: {}",
            with_image.join(", ")
        )));
    };
    let image = PathBuf::from(format!("firmware/images/{module}.elf"));
    if !root.join(&image).is_file() {
        return Err(CliError::new(format!(
            "{} is missing: build the images with `make firmware` (scripts/firmware build {module})",
            image.display()
        )));
    }
    let behind_bootloader =
        entry.get("image").and_then(|i| i.get("slot")).and_then(|s| s.as_str()) == Some("active");
    let bootloader = if behind_bootloader { Some(bootloader_image(root, chip)?) } else { None };
    Ok(FlashTarget { module: module.to_string(), chip: chip.to_string(), image, bootloader })
}

/// The committed bootloader image for `chip` (firmware/images.toml's image of package
/// `bootloader` on that MCU).
fn bootloader_image(root: &Path, chip: &str) -> Result<PathBuf, CliError> {
    let path = root.join("firmware/images.toml");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
    let images: toml::Table =
        toml::from_str(&text).map_err(|e| CliError::new(format!("{}: {e}", path.display())))?;
    let name = images
        .get("image")
        .and_then(|i| i.as_array())
        .into_iter()
        .flatten()
        .find(|i| {
            i.get("package").and_then(|p| p.as_str()) == Some("bootloader")
                && i.get("mcu").and_then(|m| m.as_str()) == Some(chip)
        })
        .and_then(|i| i.get("name").and_then(|n| n.as_str()))
        .ok_or_else(|| {
            CliError::new(format!(
                "the image runs behind a bootloader, but firmware/images.toml has no bootloader \
                 image for {chip}"
            ))
        })?;
    let elf = PathBuf::from(format!("firmware/images/{name}.elf"));
    if !root.join(&elf).is_file() {
        return Err(CliError::new(format!(
            "{} is missing: build the images with `make firmware`",
            elf.display()
        )));
    }
    Ok(elf)
}

/// The command that installs the pinned probe-rs where `r2p flash` looks first (`make probe-rs`
/// runs it).
pub fn install_command() -> String {
    format!(
        "cargo install probe-rs-tools --version {PROBE_RS_VERSION} --locked --root .tools/probe-rs"
    )
}

/// The probe-rs to run: `explicit` if given, else the repository's `.tools` copy, else the
/// first `probe-rs` on `path` (a `PATH`-style list).
pub fn find_probe_rs(
    root: &Path,
    explicit: Option<&Path>,
    path: Option<&OsStr>,
) -> Result<PathBuf, CliError> {
    if let Some(p) = explicit {
        return if p.is_file() {
            Ok(p.to_path_buf())
        } else {
            Err(CliError::new(format!("--probe-rs {}: no such file", p.display())))
        };
    }
    let local = root.join(PROBE_RS_LOCAL);
    if local.is_file() {
        return Ok(local);
    }
    if let Some(found) = path
        .into_iter()
        .flat_map(std::env::split_paths)
        .map(|d| d.join("probe-rs"))
        .find(|p| p.is_file())
    {
        return Ok(found);
    }
    Err(CliError::new(format!(
        "probe-rs is not installed (looked in {PROBE_RS_LOCAL} and on PATH). Install probe-rs \
         {PROBE_RS_VERSION}, once (~15 min on 2 cores): `make probe-rs`, which runs `{}` in the \
         repository; or get a release from https://probe.rs and put it on PATH",
        install_command()
    )))
}

/// The probes `probe-rs list` names (one `[N]: …` line each).
pub fn listed_probes(output: &str) -> Vec<String> {
    output
        .lines()
        .filter_map(|l| {
            let (n, rest) = l.trim().strip_prefix('[')?.split_once("]: ")?;
            n.parse::<usize>().ok().map(|_| rest.trim().to_string())
        })
        .collect()
}

/// The version a `probe-rs --version` line reports (`probe-rs 0.32.0 (git commit: …)`).
pub fn reported_version(output: &str) -> Option<&str> {
    output.split_whitespace().nth(1)
}

/// The options that pick the chip and the probe, shared by the download and the reset.
fn probe_options(t: &FlashTarget, args: &FlashArgs) -> Vec<OsString> {
    let mut v: Vec<OsString> = vec!["--chip".into(), t.chip.clone().into()];
    if let Some(p) = &args.probe {
        v.extend(["--probe".into(), p.into()]);
    }
    if args.connect_under_reset {
        v.push("--connect-under-reset".into());
    }
    v
}

/// `probe-rs download …`: writes an image (the module's, or its bootloader) and reads it back
/// (`--verify`).
pub fn download_args(
    t: &FlashTarget,
    args: &FlashArgs,
    root: &Path,
    image: &Path,
) -> Vec<OsString> {
    let mut v: Vec<OsString> = vec!["download".into()];
    v.extend(probe_options(t, args));
    v.extend(["--verify".into(), root.join(image).into()]);
    v
}

/// `probe-rs reset …`: starts the image just written.
pub fn reset_args(t: &FlashTarget, args: &FlashArgs) -> Vec<OsString> {
    let mut v: Vec<OsString> = vec!["reset".into()];
    v.extend(probe_options(t, args));
    v
}

/// A command as a shell line, for `--dry-run` and error messages.
fn shell_line(exe: &Path, args: &[OsString]) -> String {
    std::iter::once(exe.as_os_str())
        .chain(args.iter().map(OsString::as_os_str))
        .map(|a| a.to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs `r2p flash`.
pub fn run(args: &FlashArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let root = repository(args.root.as_deref(), "flash")?;
    flash(args, &root, std::env::var_os("PATH").as_deref(), out)
}

/// The R2P repository a command works in: `--root`'s, else the one around the current folder,
/// else the one around `r2p` itself; `command` names the command in the error.
pub fn repository(root: Option<&Path>, command: &str) -> Result<PathBuf, CliError> {
    match root {
        Some(r) => find_root(r).ok_or_else(|| {
            CliError::new(format!("--root {}: no modules.toml there or above", r.display()))
        }),
        None => std::env::current_dir()
            .ok()
            .and_then(|d| find_root(&d))
            .or_else(|| std::env::current_exe().ok().and_then(|e| find_root(&e)))
            .ok_or_else(|| {
                CliError::new(format!(
                    "not inside an R2P repository (no modules.toml here or above): run r2p \
                     {command} from the repository, or give --root DIR"
                ))
            }),
    }
}

/// `r2p flash` in the repository `root`, looking for probe-rs on `path`.
pub fn flash(
    args: &FlashArgs,
    root: &Path,
    path: Option<&OsStr>,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let target = flash_target(root, &args.module)?;
    let exe = match find_probe_rs(root, args.probe_rs.as_deref(), path) {
        Ok(exe) => exe,
        // A dry run shows the commands even where probe-rs is not installed yet.
        Err(_) if args.dry_run && args.probe_rs.is_none() => PathBuf::from("probe-rs"),
        Err(e) => return Err(e),
    };
    // The bootloader first (an image behind one), then the image, then a reset.
    let mut steps: Vec<(&str, Vec<OsString>)> = Vec::new();
    if let Some(b) = &target.bootloader {
        steps.push(("writing the bootloader", download_args(&target, args, root, b)));
    }
    steps.push(("writing the image", download_args(&target, args, root, &target.image)));
    steps.push(("resetting the module", reset_args(&target, args)));
    if args.dry_run {
        for (_, cmd) in &steps {
            emit(out, &shell_line(&exe, cmd))?;
        }
        return Ok(());
    }
    let capture = |what: &[&str]| {
        Command::new(&exe).args(what).output().map_err(|e| {
            CliError::new(format!(
                "running {} failed: {e}",
                shell_line(&exe, &[what.join(" ").into()])
            ))
        })
    };
    let version = capture(&["--version"])?;
    let version = String::from_utf8_lossy(&version.stdout).into_owned();
    if reported_version(&version) != Some(PROBE_RS_VERSION) {
        emit(
            out,
            &format!(
                "note: {} is {}, not the pinned {PROBE_RS_VERSION} (`make probe-rs` installs it)",
                exe.display(),
                version.trim()
            ),
        )?;
    }
    let list = capture(&["list"])?;
    let probes = listed_probes(&String::from_utf8_lossy(&list.stdout));
    if probes.is_empty() {
        return Err(CliError::new(format!(
            "no debug probe found (`{} list` lists none): plug an SWD probe (ST-Link, J-Link or a \
             CMSIS-DAP probe) into USB, wire it to the module's SWD header and power the module \
             ({GUIDE}); on Linux, install probe-rs's udev rules (https://probe.rs/docs/getting-started/probe-setup/)",
            exe.display()
        )));
    }
    if probes.len() > 1 && args.probe.is_none() {
        return Err(CliError::new(format!(
            "{} probes are attached: choose one with --probe VID:PID[:SERIAL]: {}",
            probes.len(),
            probes.join("; ")
        )));
    }
    emit(
        out,
        &format!(
            "flashing {} ({}) to its {} …",
            target.module,
            target.image.display(),
            target.chip
        ),
    )?;
    for (what, cmd) in &steps {
        let status = Command::new(&exe)
            .args(cmd)
            .status()
            .map_err(|e| CliError::new(format!("running {} failed: {e}", exe.display())))?;
        if !status.success() {
            return Err(CliError::new(format!(
                "{what} failed (`{}` exited {}; probe-rs's message is above): check the probe's \
                 wiring and the module's power; a board that will not attach may need \
                 --connect-under-reset or recovery through BOOT0 ({GUIDE})",
                shell_line(&exe, cmd),
                status.code().map_or("on a signal".to_string(), |c| c.to_string())
            )));
        }
    }
    emit(
        out,
        &format!("flashed {}: the module is running {}", target.module, target.image.display()),
    )
}

#[cfg(test)]
mod tests {
    use std::os::unix::fs::PermissionsExt;
    use std::sync::atomic::{AtomicU32, Ordering};
    use std::sync::{Mutex, MutexGuard};

    use super::*;

    fn repo() -> PathBuf {
        find_root(Path::new(env!("CARGO_MANIFEST_DIR"))).expect("the repository")
    }

    fn args(module: &str) -> FlashArgs {
        FlashArgs {
            module: module.into(),
            probe: None,
            connect_under_reset: false,
            dry_run: false,
            probe_rs: None,
            root: None,
        }
    }

    /// A fresh empty folder under the system's temporary folder.
    fn scratch() -> PathBuf {
        static N: AtomicU32 = AtomicU32::new(0);
        let d = std::env::temp_dir().join(format!(
            "r2p-flash-test-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// Held by each test that writes and runs a stand-in probe-rs: a script still open for
    /// writing in one thread while another forks cannot be executed (ETXTBSY).
    fn exclusive() -> MutexGuard<'static, ()> {
        static LOCK: Mutex<()> = Mutex::new(());
        LOCK.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A stand-in for probe-rs: logs its arguments, one call per line, and answers `list` with
    /// `list_output`; exits `status` for `download`.
    fn fake_probe_rs(dir: &Path, list_output: &str, status: i32) -> (PathBuf, PathBuf) {
        let exe = dir.join("probe-rs");
        let log = dir.join("calls.log");
        std::fs::write(
            &exe,
            format!(
                "#!/bin/sh\necho \"$*\" >> '{}'\ncase \"$1\" in\n  --version) echo 'probe-rs 0.32.0 (git commit: x)';;\n  list) printf '{}';;\n  download) exit {status};;\nesac\n",
                log.display(),
                list_output
            ),
        )
        .unwrap();
        std::fs::set_permissions(&exe, std::fs::Permissions::from_mode(0o755)).unwrap();
        (exe, log)
    }

    const ONE_PROBE: &str =
        "The following debug probes were found:\\n[0]: STLink V2 -- 0483:3748:0671FF (ST-LINK)\\n";

    #[test]
    fn every_module_with_an_image_maps_to_its_committed_elf_and_chip() {
        let root = repo();
        let t = flash_target(&root, "motor").unwrap();
        assert_eq!(t.chip, "STM32F103CB");
        assert_eq!(t.image, Path::new("firmware/images/motor.elf"));
        // Behind the F103's bootloader: written first.
        assert_eq!(t.bootloader.as_deref(), Some(Path::new("firmware/images/bootloader-f103.elf")));
        let t = flash_target(&root, "gateway").unwrap();
        assert_eq!(t.chip, "STM32F407VG");
        assert_eq!(t.image, Path::new("firmware/images/gateway.elf"));
        // Behind its MCU's bootloader: written first.
        assert_eq!(t.bootloader.as_deref(), Some(Path::new("firmware/images/bootloader-f407.elf")));
        let err = flash_target(&root, "servo").unwrap_err().to_string();
        assert!(err.contains("no module named \"servo\""), "{err}");
        // footprint images are not modules: flash names modules only.
        assert!(flash_target(&root, "footprint-f103").is_err());
    }

    #[test]
    fn a_missing_image_says_how_to_build_it() {
        let d = scratch();
        std::fs::create_dir_all(d.join("firmware")).unwrap();
        std::fs::write(d.join("firmware/images.toml"), "").unwrap();
        std::fs::write(
            d.join("modules.toml"),
            "[[module]]\nname = \"psu\"\nimage = { mcu = \"STM32F103CB\" }\n",
        )
        .unwrap();
        let err = flash_target(&d, "psu").unwrap_err().to_string();
        assert!(err.contains("firmware/images/psu.elf is missing"), "{err}");
        assert!(err.contains("make firmware"), "{err}");
        // A module without an image yet.
        std::fs::write(
            d.join("modules.toml"),
            "[[module]]\nname = \"psu\"\nimage = { mcu = \"STM32F103CB\" }\n\n[[module]]\nname = \"servo\"\n",
        )
        .unwrap();
        let err = flash_target(&d, "servo").unwrap_err().to_string();
        assert!(err.contains("servo has no firmware image"), "{err}");
        assert!(err.contains("psu"), "{err}");
        assert_eq!(find_root(&d.join("firmware/images")), Some(d.clone()));
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn an_image_not_in_a_slot_is_flashed_alone() {
        // A new module's image, linked at the flash base until it fits a slot: no bootloader.
        let d = scratch();
        std::fs::create_dir_all(d.join("firmware/images")).unwrap();
        std::fs::write(d.join("firmware/images.toml"), "").unwrap();
        std::fs::write(d.join("firmware/images/servo.elf"), "").unwrap();
        std::fs::write(
            d.join("modules.toml"),
            "[[module]]\nname = \"servo\"\nimage = { mcu = \"STM32F103CB\" }\n",
        )
        .unwrap();
        let t = flash_target(&d, "servo").unwrap();
        assert_eq!((t.chip.as_str(), t.bootloader), ("STM32F103CB", None));
        assert_eq!(t.image, Path::new("firmware/images/servo.elf"));
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn the_commands_name_the_chip_the_probe_and_the_image() {
        let root = repo();
        let t = flash_target(&root, "psu").unwrap();
        let mut a = args("psu");
        let image = root.join("firmware/images/psu.elf");
        assert_eq!(
            download_args(&t, &a, &root, &t.image),
            ["download", "--chip", "STM32F103CB", "--verify"]
                .map(OsString::from)
                .into_iter()
                .chain([image.clone().into()])
                .collect::<Vec<_>>()
        );
        a.probe = Some("0483:3748".into());
        a.connect_under_reset = true;
        assert_eq!(
            reset_args(&t, &a),
            ["reset", "--chip", "STM32F103CB", "--probe", "0483:3748", "--connect-under-reset"]
                .map(OsString::from)
        );
    }

    #[test]
    fn probe_rs_is_taken_from_tools_then_path_else_the_error_gives_the_install_command() {
        let d = scratch();
        let bin = d.join("bin");
        std::fs::create_dir_all(&bin).unwrap();
        let err = find_probe_rs(&d, None, Some(bin.as_os_str())).unwrap_err().to_string();
        assert!(
            err.contains(
                "cargo install probe-rs-tools --version 0.32.0 --locked --root .tools/probe-rs"
            ),
            "{err}"
        );
        assert!(err.contains("make probe-rs"), "{err}");
        std::fs::write(bin.join("probe-rs"), "").unwrap();
        assert_eq!(find_probe_rs(&d, None, Some(bin.as_os_str())).unwrap(), bin.join("probe-rs"));
        std::fs::create_dir_all(d.join(".tools/probe-rs/bin")).unwrap();
        std::fs::write(d.join(PROBE_RS_LOCAL), "").unwrap();
        assert_eq!(find_probe_rs(&d, None, Some(bin.as_os_str())).unwrap(), d.join(PROBE_RS_LOCAL));
        let err = find_probe_rs(&d, Some(&d.join("nope")), None).unwrap_err().to_string();
        assert!(err.contains("no such file"), "{err}");
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn probe_list_and_version_lines_are_read() {
        assert!(listed_probes("No debug probes were found.\n").is_empty());
        assert_eq!(
            listed_probes(
                "The following debug probes were found:\n[0]: STLink V2 -- 0483:3748:1 (ST-LINK)\n[1]: J-Link -- 1366:0101:2 (J-Link)\n"
            ),
            ["STLink V2 -- 0483:3748:1 (ST-LINK)", "J-Link -- 1366:0101:2 (J-Link)"]
        );
        assert_eq!(reported_version("probe-rs 0.32.0 (git commit: abc)\n"), Some("0.32.0"));
    }

    #[test]
    fn flash_writes_then_resets_through_probe_rs() {
        let _one_at_a_time = exclusive();
        let d = scratch();
        let (exe, log) = fake_probe_rs(&d, ONE_PROBE, 0);
        let root = repo();
        let mut a = args("motor");
        a.probe_rs = Some(exe);
        let mut out = Vec::new();
        flash(&a, &root, None, &mut out).unwrap();
        let calls = std::fs::read_to_string(&log).unwrap();
        let image = root.join("firmware/images/motor.elf");
        let bootloader = root.join("firmware/images/bootloader-f103.elf");
        assert_eq!(
            calls.lines().collect::<Vec<_>>(),
            [
                "--version".to_string(),
                "list".to_string(),
                format!("download --chip STM32F103CB --verify {}", bootloader.display()),
                format!("download --chip STM32F103CB --verify {}", image.display()),
                "reset --chip STM32F103CB".to_string(),
            ]
        );
        let out = String::from_utf8(out).unwrap();
        assert!(out.contains("flashed motor"), "{out}");
        assert!(!out.contains("note:"), "the pinned version draws no note: {out}");
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn no_probe_several_probes_and_a_failed_write_are_clear_errors() {
        let _one_at_a_time = exclusive();
        let root = repo();
        let d = scratch();
        let (exe, log) = fake_probe_rs(&d, "No debug probes were found.\\n", 0);
        let mut a = args("motor");
        a.probe_rs = Some(exe);
        let err = flash(&a, &root, None, &mut Vec::new()).unwrap_err().to_string();
        assert!(err.starts_with("no debug probe found"), "{err}");
        assert!(err.contains("SWD header") && err.contains(GUIDE), "{err}");
        assert!(!std::fs::read_to_string(&log).unwrap().contains("download"));

        let two = "[0]: STLink -- 0483:3748:1 (ST-LINK)\\n[1]: J-Link -- 1366:0101:2 (J-Link)\\n";
        let (exe, log) = fake_probe_rs(&d, two, 0);
        a.probe_rs = Some(exe.clone());
        let err = flash(&a, &root, None, &mut Vec::new()).unwrap_err().to_string();
        assert!(err.contains("2 probes are attached") && err.contains("--probe"), "{err}");
        a.probe = Some("1366:0101:2".into());
        flash(&a, &root, None, &mut Vec::new()).unwrap();
        assert!(std::fs::read_to_string(&log)
            .unwrap()
            .contains("reset --chip STM32F103CB --probe 1366:0101:2"));

        let (exe, log) = fake_probe_rs(&d, ONE_PROBE, 1);
        a.probe_rs = Some(exe);
        std::fs::remove_file(&log).ok();
        let err = flash(&a, &root, None, &mut Vec::new()).unwrap_err().to_string();
        assert!(err.starts_with("writing the bootloader failed"), "{err}");
        assert!(
            !std::fs::read_to_string(&log).unwrap().contains("reset"),
            "no reset after a failed write"
        );
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn dry_run_prints_the_commands_and_runs_nothing() {
        let _one_at_a_time = exclusive();
        let d = scratch();
        let (exe, log) = fake_probe_rs(&d, ONE_PROBE, 0);
        let root = repo();
        // The motor's image, behind the F103's bootloader: the bootloader first.
        let mut a = args("motor");
        a.probe_rs = Some(exe.clone());
        a.dry_run = true;
        let mut out = Vec::new();
        flash(&a, &root, None, &mut out).unwrap();
        let image = root.join("firmware/images/motor.elf");
        let bootloader = root.join("firmware/images/bootloader-f103.elf");
        assert_eq!(
            String::from_utf8(out).unwrap(),
            format!(
                "{e} download --chip STM32F103CB --verify {}\n\
                 {e} download --chip STM32F103CB --verify {}\n{e} reset --chip STM32F103CB\n",
                bootloader.display(),
                image.display(),
                e = exe.display()
            )
        );
        assert!(!log.exists());
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn a_dry_run_without_probe_rs_still_shows_the_commands() {
        let d = scratch();
        std::fs::create_dir_all(d.join("firmware/images")).unwrap();
        std::fs::write(d.join("firmware/images.toml"), "").unwrap();
        std::fs::write(d.join("firmware/images/psu.elf"), "").unwrap();
        std::fs::write(
            d.join("modules.toml"),
            "[[module]]\nname = \"psu\"\nimage = { mcu = \"STM32F103CB\" }\n",
        )
        .unwrap();
        let mut a = args("psu");
        a.dry_run = true;
        let mut out = Vec::new();
        flash(&a, &d, None, &mut out).unwrap();
        let out = String::from_utf8(out).unwrap();
        assert!(out.starts_with("probe-rs download --chip STM32F103CB --verify "), "{out}");
        a.dry_run = false;
        let err = flash(&a, &d, None, &mut Vec::new()).unwrap_err().to_string();
        assert!(err.starts_with("probe-rs is not installed"), "{err}");
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn the_pinned_version_is_the_one_the_target_descriptions_come_from() {
        let pin = std::fs::read_to_string(repo().join(PROBE_RS_PIN)).unwrap();
        let t: toml::Table = toml::from_str(&pin).unwrap();
        let v = t["dependencies"]["probe-rs"]["version"].as_str().unwrap();
        assert_eq!(v, format!("={PROBE_RS_VERSION}"));
    }
}
