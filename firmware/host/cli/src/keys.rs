//! `r2p keygen` and `r2p sign`: a signing key of your own, and signed images for the bootloader
//! (docs/flashing.md, "Keys"). The signature is r2p-boot's trailer; the bootloader built with a
//! key's public half accepts only images signed with it.

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::Args;
use r2p_boot::sign::{parse_key_file, public_key, sign, Meta, SignError};
use r2p_boot::Version;

use crate::error::CliError;
use crate::flash::{find_root, flash_target, repository};

/// The public development key pair, relative to the repository: anyone can sign with it.
pub const DEVELOPMENT_KEY: &str = "firmware/keys/development.key";

/// `r2p keygen` options.
#[derive(Args, Debug, Clone)]
pub struct KeygenArgs {
    /// Where to write the secret key (its public half goes to FILE.pub); never inside an R2P
    /// repository
    pub file: PathBuf,
}

/// `r2p sign` options.
#[derive(Args, Debug, Clone)]
pub struct SignArgs {
    /// The module whose committed image to sign (firmware/images/MODULE.bin), or a .bin file
    /// with --kind
    pub image: String,
    /// The image's version, MAJOR.MINOR.PATCH
    #[arg(long, value_name = "X.Y.Z")]
    pub version: String,
    /// The secret key file (`r2p keygen`); default: the public development key, with a warning
    #[arg(long, value_name = "FILE")]
    pub key: Option<PathBuf>,
    /// The module kind, when IMAGE is a file (default: the module named by IMAGE)
    #[arg(long)]
    pub kind: Option<String>,
    /// Where to write the signed image (default: IMAGE's name with .signed.bin, in the current folder)
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// The R2P repository (default: the one around the current folder)
    #[arg(long, value_name = "DIR")]
    pub root: Option<PathBuf>,
}

/// Writes a new key pair: 32 random bytes from the OS as the secret seed (mode 0600), its
/// public key beside it.
pub fn keygen(args: &KeygenArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let file = std::path::absolute(&args.file)
        .map_err(|e| CliError::new(format!("{}: {e}", args.file.display())))?;
    let parent = file.parent().unwrap_or(Path::new("/"));
    if let Some(repo) = find_root(parent) {
        return Err(CliError::new(format!(
            "{} is inside the R2P repository at {}: a secret key must never be committed; keep it \
             elsewhere (e.g. ~/.config/r2p/keys/)",
            file.display(),
            repo.display()
        )));
    }
    let public_file = PathBuf::from(format!("{}.pub", file.display()));
    for f in [&file, &public_file] {
        if f.exists() {
            return Err(CliError::new(format!("{} exists: not overwritten (a lost key cannot sign updates for the modules that trust it)", f.display())));
        }
    }
    let mut seed = [0u8; 32];
    {
        use std::io::Read;
        std::fs::File::open("/dev/urandom")
            .and_then(|mut f| f.read_exact(&mut seed))
            .map_err(|e| CliError::new(format!("/dev/urandom: {e}")))?;
    }
    std::fs::create_dir_all(parent)
        .map_err(|e| CliError::new(format!("{}: {e}", parent.display())))?;
    let secret = format!(
        "# R2P image signing key (secret). Whoever holds this file can sign images your modules accept.\n\
         # Keep it out of every repository; its public half: {}\n{}\n",
        public_file.display(),
        hex(&seed)
    );
    write_private(&file, &secret)?;
    let public = format!(
        "# R2P image signing key (public half of {}): build the bootloader with\n\
         # R2P_BOOT_PUBLIC_KEY={} (docs/flashing.md, \"Keys\").\n{}\n",
        file.display(),
        public_file.display(),
        hex(&public_key(&seed))
    );
    std::fs::write(&public_file, public)
        .map_err(|e| CliError::new(format!("{}: {e}", public_file.display())))?;
    writeln!(out, "secret key: {}\npublic key: {}", file.display(), public_file.display())
        .map_err(|e| CliError::new(e.to_string()))
}

#[cfg(unix)]
fn write_private(file: &Path, text: &str) -> Result<(), CliError> {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(file)
        .and_then(|mut f| f.write_all(text.as_bytes()))
        .map_err(|e| CliError::new(format!("{}: {e}", file.display())))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Parses MAJOR.MINOR.PATCH.
pub fn parse_version(s: &str) -> Result<Version, CliError> {
    let bad = || {
        CliError::new(format!("--version {s:?}: expected MAJOR.MINOR.PATCH, e.g. 1.4.0 (major and minor up to 255, patch up to 65535)"))
    };
    let parts: Vec<&str> = s.split('.').collect();
    let [major, minor, patch] = parts[..] else { return Err(bad()) };
    Ok(Version {
        major: major.parse().map_err(|_| bad())?,
        minor: minor.parse().map_err(|_| bad())?,
        patch: patch.parse().map_err(|_| bad())?,
    })
}

/// Signs an image: a module's committed image, or a file.
pub fn sign_image(args: &SignArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let version = parse_version(&args.version)?;
    // The module's MCU (and the development key) come from the repository, whatever is signed.
    let root = repository(args.root.as_deref(), "sign")?;
    let as_file = Path::new(&args.image);
    let (bin, kind, mcu) = if as_file.is_file() {
        let kind = args.kind.clone().ok_or_else(|| {
            CliError::new(format!(
                "{}: a file needs --kind (the module it is for, e.g. motor)",
                as_file.display()
            ))
        })?;
        let mcu = flash_target(&root, &kind)?.chip;
        (as_file.to_path_buf(), kind, mcu)
    } else if args.image.contains(std::path::MAIN_SEPARATOR) || args.image.ends_with(".bin") {
        return Err(CliError::new(format!(
            "{}: no such file (give a module's name, e.g. motor, or an image file)",
            as_file.display()
        )));
    } else {
        let t = flash_target(&root, &args.image)?;
        (root.join(t.image.with_extension("bin")), t.module, t.chip)
    };
    let image =
        std::fs::read(&bin).map_err(|e| CliError::new(format!("{}: {e}", bin.display())))?;
    let (key_file, development) = match &args.key {
        Some(k) => (k.clone(), false),
        None => (root.join(DEVELOPMENT_KEY), true),
    };
    let text = std::fs::read_to_string(&key_file).map_err(|e| {
        CliError::new(format!("{}: {e} (`r2p keygen FILE` makes a key)", key_file.display()))
    })?;
    let seed =
        parse_key_file(&text).map_err(|e| CliError::new(format!("{}: {e}", key_file.display())))?;
    let meta = Meta { version, kind: &kind, mcu: &mcu };
    let signed = sign(&image, &meta, &seed).map_err(|e| {
        CliError::new(match e {
            SignError::AlreadySigned => {
                format!("{}: already signed (it ends with a trailer)", bin.display())
            }
            SignError::BadKind => format!("kind {kind:?}: 1 to 16 printable ASCII characters"),
            SignError::BadMcu => format!("MCU {mcu:?}: 1 to 16 printable ASCII characters"),
        })
    })?;
    let dest = args.out.clone().unwrap_or_else(|| {
        PathBuf::from(format!(
            "{}.signed.bin",
            bin.file_stem().and_then(|s| s.to_str()).unwrap_or("image")
        ))
    });
    std::fs::write(&dest, &signed)
        .map_err(|e| CliError::new(format!("{}: {e}", dest.display())))?;
    let w = |e: std::io::Error| CliError::new(e.to_string());
    if development {
        writeln!(out, "warning: signed with the public development key ({DEVELOPMENT_KEY}): only bootloaders that trust it accept this image").map_err(w)?;
    }
    writeln!(
        out,
        "{}: {kind} {}.{}.{} for {mcu}, {} B + 128 B trailer, digest {}, key {}",
        dest.display(),
        version.major,
        version.minor,
        version.patch,
        image.len(),
        hex(&r2p_boot::image_digest(&image)),
        hex(&r2p_boot::key_id(&public_key(&seed)))
    )
    .map_err(w)
}
