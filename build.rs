//! Records where the `bvh` package's sources are, so that a scene file can name a mesh shipped inside
//! it (`obj = "crate:bvh/media/sponza.obj"`: the Dabrovic Sponza) without a copy in this repository.
//! Cargo has fetched the package before building us, so its folder exists on any machine that builds
//! vxgi; `cargo metadata --offline` names it. `VXGI_CRATE_BVH` at run time overrides the path.
use std::process::Command;

fn main() {
    println!("cargo:rerun-if-changed=Cargo.lock");
    println!("cargo:rerun-if-changed=build.rs");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    // Only this target's packages: cargo fetched those for this build (the others, e.g. Windows-only
    // crates, may not be on the machine, and --offline cannot fetch them).
    let target = std::env::var("TARGET").expect("cargo sets it");
    let metadata = |offline: bool| {
        let mut c = Command::new(&cargo);
        c.args(["metadata", "--format-version", "1", "--locked"])
            .args(["--filter-platform", &target])
            .current_dir(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
        if offline {
            c.arg("--offline");
        }
        c.output()
    };
    let out = match metadata(true) {
        Ok(o) if o.status.success() => Ok(o),
        // Online, cargo reaches only the package registry.
        _ => metadata(false),
    };
    let dir = match out {
        Ok(o) if o.status.success() => {
            let json = String::from_utf8_lossy(&o.stdout);
            json.split("\"manifest_path\":\"")
                .skip(1)
                .filter_map(|s| s.split('"').next())
                // JSON escapes a Windows path's backslashes.
                .map(|p| p.replace("\\\\", "/"))
                .find(|p| {
                    p.ends_with("/Cargo.toml")
                        // The registry's folder `bvh-<version>`, not another crate named `bvh-...`.
                        && p.rsplit('/').nth(1).is_some_and(|d| {
                            d.strip_prefix("bvh-")
                                .is_some_and(|v| v.starts_with(|c: char| c.is_ascii_digit()))
                        })
                })
                .map(|p| p.trim_end_matches("/Cargo.toml").to_string())
        }
        _ => None,
    };
    match dir {
        Some(d) => println!("cargo:rustc-env=VXGI_CRATE_BVH={d}"),
        None => {
            println!("cargo:warning=could not locate the bvh package (cargo metadata failed): scenes naming crate:bvh/... need VXGI_CRATE_BVH set");
            println!("cargo:rustc-env=VXGI_CRATE_BVH=");
        }
    }
}
