//! `vxgi export`: a kernel as one self-contained WGSL file for another renderer — its includes
//! composed in, an interface header from naga reflection (entry, workgroup size, every binding's
//! group, slot, access and layout), checked by parsing the exported text again.
use crate::common;

use common::vxgi;
use vxgi::harness::shader::{BindingKind, Shader};

/// Every declared kernel: the exported text parses and validates on its own, reflects the same
/// bindings as the kernel the harness runs, keeps the composed source verbatim after its header, and
/// the header names the entry and each binding the entry uses with its group and slot.
#[test]
fn every_kernel_exports_to_wgsl_that_validates_alone_with_its_interface() {
    for k in vxgi::kernels::all() {
        let d = k.decl();
        let text = d.export().unwrap_or_else(|e| panic!("{}: {e}", d.name));
        let again = Shader::from_wgsl(&format!("{}.wgsl (exported)", d.name), &text)
            .unwrap_or_else(|e| panic!("{}: the exported WGSL does not validate: {e}", d.name));
        let original = d.shader().unwrap();
        let key = |s: &Shader| -> Vec<(u32, u32, String, String, BindingKind)> {
            s.bindings
                .iter()
                .map(|b| {
                    (
                        b.group,
                        b.binding,
                        b.name.clone(),
                        b.ty.clone(),
                        b.kind.clone(),
                    )
                })
                .collect()
        };
        assert_eq!(key(&again), key(&original), "{}", d.name);
        assert!(
            text.ends_with(&d.composed_source()),
            "{}: the source after the header must be the composed source",
            d.name
        );
        let header: String = text
            .lines()
            .take_while(|l| l.starts_with("//"))
            .collect::<Vec<_>>()
            .join("\n");
        let entry = original.entry(d.entry).unwrap();
        let wg = entry.workgroup_size;
        assert!(
            header.contains(&format!(
                "entry `{}`, @workgroup_size({}, {}, {})",
                d.entry, wg[0], wg[1], wg[2]
            )),
            "{}: {header}",
            d.name
        );
        for &i in &entry.uses {
            let b = &original.bindings[i];
            let line = format!("@group({}) @binding({}) {}", b.group, b.binding, b.name);
            assert!(
                header.contains(&line),
                "{}: no `{line}` in\n{header}",
                d.name
            );
        }
        assert!(header.contains(d.mirror), "{}: the mirror is named", d.name);
    }
}

#[test]
fn export_writes_a_file_or_every_kernel_into_a_folder() {
    let dir = std::env::temp_dir().join(format!("vxgi_export_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // One kernel to stdout.
    let (code, out, err) = vxgi(&["export", "cone_trace"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("fn march(") && out.contains("@group(0) @binding(7) cone_dirs"),
        "{out}"
    );
    // One kernel to a file.
    let file = dir.join("one").join("cone_trace.wgsl");
    let (code, _, err) = vxgi(&["export", "cone_trace", "--out", file.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), out);
    // Every kernel into a folder, one file each.
    let all = dir.join("all");
    let (code, _, err) = vxgi(&["export", "all", "--out", all.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    for k in vxgi::kernels::all() {
        let p = all.join(format!("{}.wgsl", k.decl().name));
        assert!(p.is_file(), "{} missing", p.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn export_refuses_an_unknown_kernel_and_all_without_a_folder() {
    let (code, _, err) = vxgi(&["export", "nope"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("no kernel named `nope`") && err.contains("cone_trace"),
        "{err}"
    );
    let (code, _, err) = vxgi(&["export", "all"]);
    assert_ne!(code, 0);
    assert!(err.contains("--out"), "{err}");
}
