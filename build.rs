//! Embeds the FMU slave library in the `mtwin` binary (feature `embed-fmu`, on by
//! default), so `mtwin export` works from an installed binary (`cargo install --path .`)
//! with nothing next to it.
//!
//! The slave is this workspace's `mtwin-fmu` cdylib. A build script cannot depend on a
//! cdylib artifact (artifact dependencies are unstable), so it builds it with a nested
//! `cargo build --release -p mtwin-fmu --lib` into `<target>/fmu-embed` (shared by every
//! profile of the outer build, incremental) and copies `libmtwin_fmu.so` to `OUT_DIR`.
//! Non-Linux hosts skip the embedding (the FMU's binaries folder is `linux64` only).

use std::path::{Path, PathBuf};
use std::process::Command;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(mtwin_embedded_fmu)");
    println!("cargo::rerun-if-env-changed=MTWIN_NO_EMBED_FMU");
    for p in [
        "fmu/src",
        "fmu/Cargo.toml",
        "core/src",
        "core/Cargo.toml",
        "Cargo.lock",
    ] {
        println!("cargo::rerun-if-changed={p}");
    }
    let wanted = std::env::var_os("CARGO_FEATURE_EMBED_FMU").is_some()
        && std::env::var_os("MTWIN_NO_EMBED_FMU").is_none()
        && std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux");
    if !wanted {
        return;
    }
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
    let manifest_dir = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("dir"));
    // OUT_DIR = <target>/<profile>/build/<pkg-hash>/out (or <target>/<triple>/<profile>/...)
    let target = out
        .ancestors()
        .find(|a| a.file_name().is_some_and(|n| n == "build"))
        .and_then(Path::parent)
        .and_then(Path::parent)
        .map(Path::to_path_buf)
        .unwrap_or_else(|| out.clone());
    let nested = target.join("fmu-embed");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.args([
        "build",
        "--release",
        "-p",
        "mtwin-fmu",
        "--lib",
        "--manifest-path",
    ])
    .arg(manifest_dir.join("Cargo.toml"))
    .arg("--target-dir")
    .arg(&nested);
    // the outer build's per-package settings must not leak into the nested one
    for (k, _) in std::env::vars_os() {
        let k = k.to_string_lossy().into_owned();
        if k.starts_with("CARGO_FEATURE_")
            || k.starts_with("CARGO_CFG_")
            || k.starts_with("CARGO_PKG_")
            || k.starts_with("CARGO_MANIFEST_")
            || matches!(
                k.as_str(),
                "CARGO_ENCODED_RUSTFLAGS"
                    | "RUSTC_WORKSPACE_WRAPPER"
                    | "CARGO_TARGET_DIR"
                    | "CARGO_BUILD_TARGET_DIR"
                    | "OUT_DIR"
                    | "TARGET"
                    | "HOST"
                    | "PROFILE"
                    | "OPT_LEVEL"
                    | "DEBUG"
                    | "NUM_JOBS"
                    | "CARGO_PRIMARY_PACKAGE"
                    | "CLIPPY_ARGS"
                    | "CLIPPY_CONF_DIR"
            )
        {
            cmd.env_remove(k);
        }
    }
    let status = cmd.status();
    let so = nested.join("release").join("libmtwin_fmu.so");
    match status {
        Ok(s) if s.success() && so.is_file() => {
            std::fs::copy(&so, out.join("libmtwin_fmu.so")).expect("copy libmtwin_fmu.so");
            println!("cargo::rustc-cfg=mtwin_embedded_fmu");
        }
        other => {
            // not fatal: `mtwin export` then looks for the library next to the binary
            println!(
                "cargo::warning=could not build the FMU slave library to embed ({other:?}); \
                 `mtwin export` will look for libmtwin_fmu.so next to the binary"
            );
        }
    }
}
